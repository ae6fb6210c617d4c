// Lookups at given (Sf, Sb, l): fragment.wgsl's `shade_segment`, the
// function every rendered fragment calls, evaluated for a list of triples
// so tests and measurements compare it with the CPU shader (`Table3d::lookup`,
// `PolyTable::lookup`, …) and with the exact integral directly
// (`GpuShader::probe`).

@group(0) @binding(0) var<uniform> fr: Frame;
@group(0) @binding(12) var<storage, read> probe_in: array<vec4<f32>>;
@group(0) @binding(13) var<storage, read_write> probe_out: array<vec4<f32>>;

@compute @workgroup_size(64)
fn probe(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if i >= arrayLength(&probe_out) {
        return;
    }
    let q = probe_in[2u * i];
    let g = probe_in[2u * i + 1u];
    var seg: Seg;
    seg.sf = q.x;
    seg.sb = q.y;
    seg.len = q.z;
    seg.ok = true;
    seg.gf = g.x;
    seg.gb = g.y;
    probe_out[i] = shade_segment(fr, seg);
}
