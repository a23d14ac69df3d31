// The pin influence product on the GPU (tacsim-sim `gpu/pins.rs`): the sums of
// `contact/pin_motion.rs` (`CellForces::motion_by_lanes` and `CellForces::displacements`) in f64, in
// the CPU's order. One invocation per pin point: from every loaded cell of its state, far
// cells grouped in blocks and super-blocks, near ones split in sub-squares, on the half-space
// the displacement (mm) and rotation (rad) at the point, z into the body; on layers the
// displacements at the point's 4-point finite-difference stencil.

struct Params {
    points: u32,
    kernel: u32,
    table_rows: u32,
    pad2: u32,
    points_at: u32,
    samples_at: u32,
    supers_at: u32,
    blocks_at: u32,
    cells_at: u32,
    kernel_at: u32,
    point_sample_at: u32,
    sample_ints_at: u32,
    super_members_at: u32,
    block_members_at: u32,
    points_near_at: u32,
    pad1: u32,
};

@group(0) @binding(0) var<uniform> params: Params;
// Everything real, at the offsets in `params` (`pins.rs`, `pack`).
@group(0) @binding(1) var<storage, read> reals: array<f64>;
// Everything integer: each point's state; per state its first super-block, super-block count,
// sub-squares a side and a spare; super-blocks' and blocks' member ranges.
@group(0) @binding(2) var<storage, read> ints: array<u32>;
// Per point 12 f64s: on the half-space the displacement and the rotation (6), on layers per
// stencil point x, y, z.
@group(0) @binding(3) var<storage, read_write> out: array<f64>;

var<private> stencil: array<vec3<f64>, 4>;
var<private> depth: array<f64, 4>;
var<private> acc: array<vec3<f64>, 4>;

struct Motion {
    u: vec3<f64>,
    w: vec3<f64>,
};

// `kernel.rs`, `DepthKernel::motion`: Boussinesq and Cerruti at depth z, the displacement and
// its rotation in closed form.
fn half_space(f: vec3<f64>, x: f64, y: f64, z: f64) -> Motion {
    let at = params.kernel_at;
    let c = reals[at];
    let k = reals[at + 1u];
    let two_one_minus_nu = reals[at + 2u];
    let qx = f.x;
    let qy = f.y;
    let p = f.z;
    let rho = sqrt(x * x + y * y + z * z);
    let ir = 1.0lf / rho;
    let ir3 = ir * ir * ir;
    let irz = 1.0lf / (rho + z);
    let ir_irz = ir * irz;
    let ir_irz2 = ir_irz * irz;
    let b = p * (z * ir3 - k * ir_irz);
    let xy = x * y * (ir3 - k * ir_irz2);
    let ux = b * x + qx * (ir + x * x * ir3 + k * (irz - x * x * ir_irz2)) + qy * xy;
    let uy = b * y + qy * (ir + y * y * ir3 + k * (irz - y * y * ir_irz2)) + qx * xy;
    let uz = p * (z * z * ir3 + two_one_minus_nu * ir) + (qx * x + qy * y) * (z * ir3 + k * ir_irz);
    let g1 = ir3 * irz + ir_irz * ir_irz;
    let zr3 = z * ir3;
    let pn = two_one_minus_nu * p * ir3;
    let kxy = k * x * y * g1;
    let wx = -pn * y - kxy * qx + (k * ir_irz + zr3 - k * y * y * g1) * qy;
    let wy = pn * x + (k * x * x * g1 - k * ir_irz - zr3) * qx + kxy * qy;
    let wz = (qx * y - qy * x) * ir3;
    return Motion(vec3<f64>(c * ux, c * uy, c * uz), vec3<f64>(c * wx, c * wy, c * wz));
}

// `layered.rs`, `LayeredKernels::lerp`: Catmull-Rom in r over the 5-column table at `table`;
// the row at r = -dr from the columns' parity.
fn lerp5(table: u32, r: f64) -> array<f64, 5> {
    let at = params.kernel_at;
    let t = min(r / reals[at], f64(params.table_rows - 3u));
    let i = u32(t);
    let f = t - f64(i);
    var o: array<f64, 5>;
    for (var j = 0u; j < 5u; j++) {
        let b = reals[table + 5u * i + j];
        let c = reals[table + 5u * (i + 1u) + j];
        let d = reals[table + 5u * (i + 2u) + j];
        var a: f64;
        if (i > 0u) {
            a = reals[table + 5u * (i - 1u) + j];
        } else {
            a = reals[at + 2u + j] * c;
        }
        o[j] = b + 0.5lf * f * (c - a + f * (2.0lf * a - 5.0lf * b + 4.0lf * c - d + f * (3.0lf * (b - c) + d - a)));
    }
    return o;
}

// `layered.rs`, `combine`.
fn combine(force: vec3<f64>, x: f64, y: f64, zz: f64, pr: f64, zq: f64, s: f64, d: f64) -> vec3<f64> {
    let qx = force.x;
    let qy = force.y;
    let p = force.z;
    let r2 = x * x + y * y;
    var c = 0.0lf;
    var sn = 0.0lf;
    var c2 = 0.0lf;
    var s2 = 0.0lf;
    if (r2 > 0.0lf) {
        let r = sqrt(r2);
        c = x / r;
        sn = y / r;
        c2 = (x * x - y * y) / r2;
        s2 = 2.0lf * x * y / r2;
    }
    return vec3<f64>(
        p * pr * c + qx * (s - c2 * d) - qy * s2 * d,
        p * pr * sn - qx * s2 * d + qy * (s + c2 * d),
        p * zz + zq * (qx * c + qy * sn),
    );
}

// `layered.rs`, `LayeredKernels::displacement`: tables at the pin depth, linear in depth.
fn layered(force: vec3<f64>, x: f64, y: f64, z: f64) -> vec3<f64> {
    let at = params.kernel_at;
    let rows = params.table_rows;
    let r = sqrt(x * x + y * y);
    var f = lerp5(at + 7u, r);
    let dz = z - reals[at + 1u];
    if (dz != 0.0lf) {
        let d = lerp5(at + 7u + 5u * rows, r);
        for (var j = 0u; j < 5u; j++) {
            f[j] = f[j] + dz * d[j];
        }
    }
    return combine(force, x, y, f[0], f[1], f[2], f[3], f[4]);
}

// One point force `f` (N) at `(cx, cy)` (mm) on the surface, added: on the half-space the
// displacement at the point into `acc[0]` and its rotation into `acc[1]`; on layers the
// displacement at every stencil point.
fn add(cx: f64, cy: f64, f: vec3<f64>) {
    if (params.kernel == 0u) {
        let p = stencil[0];
        let m = half_space(f, p.x - cx, p.y - cy, depth[0]);
        acc[0] = acc[0] + m.u;
        acc[1] = acc[1] + m.w;
        return;
    }
    for (var s = 0u; s < 4u; s++) {
        let p = stencil[s];
        acc[s] = acc[s] + layered(f, p.x - cx, p.y - cy, depth[s]);
    }
}

// Squared distance (mm^2) from the point (its depth included) to the surface point (x, y).
fn dist2(x: f64, y: f64) -> f64 {
    let p0 = stencil[0];
    return (p0.x - x) * (p0.x - x) + (p0.y - y) * (p0.y - y) + depth[0] * depth[0];
}

fn group(at: u32) -> vec3<f64> {
    return vec3<f64>(reals[at + 2u], reals[at + 3u], reals[at + 4u]);
}

// The group (super-block or block) at `at` added as one force where its squared distance
// exceeds `limit` (mm^2); whether it was.
fn far_group(at: u32, limit: f64) -> bool {
    if (dist2(reals[at], reals[at + 1u]) > limit) {
        add(reals[at], reals[at + 1u], group(at));
        return true;
    }
    return false;
}

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let p = gid.x;
    if (p >= params.points) {
        return;
    }
    let state = ints[params.point_sample_at + p];
    let pa = params.points_at + 15u * p;
    let base_z = reals[pa + 2u];
    let sa = params.samples_at + 4u * state;
    let far2 = reals[sa];
    let super_far2 = reals[sa + 1u];
    let near2 = reals[sa + 2u];
    let dome_radius = reals[sa + 3u];
    for (var s = 0u; s < 4u; s++) {
        let q = pa + 3u + 3u * s;
        stencil[s] = vec3<f64>(reals[q], reals[q + 1u], reals[q + 2u]);
        // `PinKernel::depth`.
        if (params.kernel == 0u) {
            depth[s] = dome_radius - stencil[s].z;
        } else {
            depth[s] = reals[params.kernel_at + 1u] + base_z - stencil[s].z;
        }
        acc[s] = vec3<f64>(0.0lf, 0.0lf, 0.0lf);
    }
    let si = params.sample_ints_at + 4u * state;
    let first_super = ints[si];
    let supers = ints[si + 1u];
    let sub = ints[si + 2u];
    for (var g = first_super; g < first_super + supers; g++) {
        if (far_group(params.supers_at + 5u * g, super_far2)) {
            continue;
        }
        let blocks_end = ints[params.super_members_at + 2u * g + 1u];
        for (var b = ints[params.super_members_at + 2u * g]; b < blocks_end; b++) {
            if (far_group(params.blocks_at + 5u * b, far2)) {
                continue;
            }
            let cells_end = ints[params.block_members_at + 2u * b + 1u];
            for (var k = ints[params.block_members_at + 2u * b]; k < cells_end; k++) {
                let ca = params.cells_at + 11u * k;
                let x = reals[ca];
                let y = reals[ca + 1u];
                let f = group(ca);
                if (sub == 1u || dist2(x, y) >= near2) {
                    add(x, y, f);
                    continue;
                }
                // The cell's sub-squares (`subs`): sub-square (i, j) at the cell's point plus
                // `first + i step + i^2 curve` along x (j along y); without a step, a refined
                // cell's sub-cells: `count` (second) point forces from `first`.
                let first_x = reals[ca + 5u];
                let first_y = reals[ca + 6u];
                let step_x = reals[ca + 7u];
                let step_y = reals[ca + 8u];
                let curve_x = reals[ca + 9u];
                let curve_y = reals[ca + 10u];
                if (step_x == 0.0lf && step_y == 0.0lf) {
                    let first = u32(first_x);
                    for (var q = first; q < first + u32(first_y); q++) {
                        let pa = params.points_near_at + 5u * q;
                        add(reals[pa], reals[pa + 1u], vec3<f64>(reals[pa + 2u], reals[pa + 3u], reals[pa + 4u]));
                    }
                    continue;
                }
                let part = f / f64(sub * sub);
                for (var i = 0u; i < sub; i++) {
                    let fi = f64(i);
                    for (var j = 0u; j < sub; j++) {
                        let fj = f64(j);
                        add(x + first_x + fi * step_x + fi * fi * curve_x, y + first_y + fj * step_y + fj * fj * curve_y, part);
                    }
                }
            }
        }
    }
    for (var s = 0u; s < 4u; s++) {
        out[12u * p + 3u * s] = acc[s].x;
        out[12u * p + 3u * s + 1u] = acc[s].y;
        out[12u * p + 3u * s + 2u] = acc[s].z;
    }
}
