// The binary pin image on the GPU (tacsim-sim `gpu/raster.rs`), the rule of `raster.rs`: a
// pixel is white when some disc covers at least half of it (exact area), decided by the
// distance to the disc's centre outside a thin band around the half-coverage boundary and by
// the exact area inside it. One invocation per pixel of each image; f32 throughout, or f64
// throughout where `gpu/raster.rs` builds this text with every `f32` made `f64` (adapters
// with SHADER_F64).

struct Params {
    size: u32,
    images: u32,
    pad0: u32,
    pad1: u32,
};

@group(0) @binding(0) var<uniform> params: Params;
// Per disc, two entries: the centre's u, v rounded to f32 (px), radius r (px), unused; then
// what that rounding left of u and v (px), unused, unused.
@group(0) @binding(1) var<storage, read> discs: array<vec4<f32>>;
// Per image: first disc, disc count.
@group(0) @binding(2) var<storage, read> ranges: array<vec2<u32>>;
// Per pixel of each image, row-major: 0 or 255.
@group(0) @binding(3) var<storage, read_write> pixels: array<u32>;

// `raster.rs`: BAND_OUTER, BAND_INNER.
const BAND_OUTER: f32 = 0.03;
const BAND_INNER: f32 = 0.12;

// asin(z) for |z| <= 1/2 by its series, `ASIN_TERMS` terms past z (the last below 1e-17 of
// z): the shader's own asin may be far less precise (llvmpipe's is off by about 2e-4 rad,
// enough to turn pixels near half coverage). Term n+1 is term n times
// z^2 (2n+1)^2 / ((2n+2)(2n+3)).
const ASIN_TERMS: u32 = 26u;
fn asin_series(z: f32) -> f32 {
    let z2 = z * z;
    var term: f32 = z;
    var sum: f32 = z;
    for (var n = 0u; n < ASIN_TERMS; n++) {
        let k = f32(n);
        term = term * z2 * ((2.0 * k + 1.0) * (2.0 * k + 1.0)) / ((2.0 * k + 2.0) * (2.0 * k + 3.0));
        sum = sum + term;
    }
    return sum;
}

// asin(z) on [-1, 1]: the series, or pi/2 - 2 asin(sqrt((1 - |z|) / 2)) above 1/2.
fn asin_precise(z: f32) -> f32 {
    let a = abs(z);
    if (a <= 0.5) {
        return asin_series(z);
    }
    let v = 1.5707963267948966 - 2.0 * asin_series(sqrt(max(0.5 * (1.0 - a), 0.0)));
    return select(v, -v, z < 0.0);
}

// Antiderivative of sqrt(r^2 - x^2) for |x| <= r.
fn semicircle_integral(x: f32, r: f32) -> f32 {
    let c = clamp(x, -r, r);
    return 0.5 * (c * sqrt(max(r * r - c * c, 0.0)) + r * r * asin_precise(clamp(c / r, -1.0, 1.0)));
}

// Exact area of the disc of radius r at the origin within [x0, x1] x [y0, y1] (`box_coverage`).
fn box_coverage(x0: f32, x1: f32, y0: f32, y1: f32, r: f32) -> f32 {
    let a0 = max(x0, -r);
    let a1 = min(x1, r);
    if (a0 >= a1 || y0 >= r || y1 <= -r || y0 >= y1) {
        return 0.0;
    }
    var cuts: array<f32, 6>;
    cuts[0] = a0;
    var n = 1u;
    let bs = array<f32, 2>(y0, y1);
    for (var i = 0u; i < 2u; i++) {
        let b = bs[i];
        if (abs(b) < r) {
            let w = sqrt(r * r - b * b);
            if (-w > a0 && -w < a1) {
                cuts[n] = -w;
                n++;
            }
            if (w > a0 && w < a1) {
                cuts[n] = w;
                n++;
            }
        }
    }
    cuts[n] = a1;
    // Insertion sort of cuts[0..=n].
    for (var i = 1u; i <= n; i++) {
        let v = cuts[i];
        var j = i;
        while (j > 0u && cuts[j - 1u] > v) {
            cuts[j] = cuts[j - 1u];
            j--;
        }
        cuts[j] = v;
    }
    var area: f32 = 0.0;
    for (var i = 0u; i < n; i++) {
        let s = cuts[i];
        let t = cuts[i + 1u];
        if (t <= s) {
            continue;
        }
        let m = 0.5 * (s + t);
        let h = sqrt(max(r * r - m * m, 0.0));
        let top_is_circle = h < y1;
        let bottom_is_circle = -h > y0;
        let top_m = select(y1, h, top_is_circle);
        let bottom_m = select(y0, -h, bottom_is_circle);
        if (top_m <= bottom_m) {
            continue;
        }
        let hint = semicircle_integral(t, r) - semicircle_integral(s, r);
        let top = select(y1 * (t - s), hint, top_is_circle);
        let bottom = select(y0 * (t - s), -hint, bottom_is_circle);
        area += top - bottom;
    }
    return max(area, 0.0);
}

@compute @workgroup_size(8, 8, 1)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = params.size;
    if (id.x >= size || id.y >= size || id.z >= params.images) {
        return;
    }
    let range = ranges[id.z];
    let x = f32(id.x);
    let y = f32(id.y);
    var on = false;
    for (var k = range.x; k < range.x + range.y; k++) {
        let d = discs[2u * k];
        let lo = discs[2u * k + 1u];
        let r = d.z;
        // The pixel's corner from the centre: x - hi is exact near the disc (Sterbenz), so
        // the offset carries the centre to about 1e-7 px, not f32's 4e-6 px at 100 px.
        let ox = (x - d.x) - lo.x;
        let oy = (y - d.y) - lo.y;
        let dx = ox + 0.5;
        let dy = oy + 0.5;
        var inner2 = r * r - 0.5;
        var outer2 = r * r;
        if (r >= 1.0) {
            inner2 = (r - BAND_INNER / r) * (r - BAND_INNER / r);
            outer2 = (r - BAND_OUTER / r) * (r - BAND_OUTER / r);
        }
        let d2 = dx * dx + dy * dy;
        if (d2 <= inner2) {
            on = true;
            break;
        }
        if (d2 < outer2 && box_coverage(ox, ox + 1.0, oy, oy + 1.0, r) >= 0.5) {
            on = true;
            break;
        }
    }
    pixels[(id.z * size + id.y) * size + id.x] = select(0u, 255u, on);
}
