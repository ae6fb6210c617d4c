//! GPU pre-integration against the CPU bake: for each table3d resolution,
//! bakes the table on the CPU (tet_preint, rayon over every core) and on
//! the GPU (bake.wgsl) with f32 and with f16 accumulation, and prints
//! the bake times (best of REPEATS) and the errors:
//! * against `exact` over the domain: N triples uniform over the baked band
//!   (`uniform_triples`, fixed seed), each table looked up as a fragment
//!   would (the CPU table by `Table3d::lookup`, the GPU tables by the
//!   renderer's own lookup through `GpuShader::probe_table3d`);
//! * GPU entries against the CPU table's, over every stored entry;
//!
//! then the same for the poly1/2/4 tables (`tet_gpu::bake_poly` against
//! `PolyTable::build`; both looked up on the CPU).
//!
//! cargo run --release -p tet_gpu --example gpu_bake -- [TF.json] [S_LO S_HI MAX_DS LEN_MAX] [N] [REPEATS]
//!
//! Defaults: formats/samples/tf_normalized.json over the NASA Blunt Fin
//! bundle's domain (density in [0.1926, 4.9775], |Sf − Sb| ≤ 2.0032,
//! l ≤ 3.6486; crates/tetlut/results/bluntfin.md), N = 200 000, REPEATS = 3,
//! resolutions 32×32×64, 64×64×128 and 128×128×256, tf-nodes axis.

use std::time::Instant;
use tet_gpu::{GpuAccumulation, GpuContext, GpuShader, GpuTable3d};
use tet_preint::{
    integrate_segment_with, tf_for_domain, uniform_triples, Table3d, Table3dParams, TableDomain, TransferFunction,
};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let tf_path = args.first().cloned().unwrap_or_else(|| {
        concat!(env!("CARGO_MANIFEST_DIR"), "/../../formats/samples/tf_normalized.json").to_string()
    });
    let num = |i: usize, d: f64| args.get(i).map_or(Ok(d), |s| s.parse::<f64>());
    let domain = TableDomain::new(num(1, 0.1926)?, num(2, 4.9775)?, num(3, 2.0032)?, num(4, 3.6486)?)?;
    let n = num(5, 200_000.0)? as usize;
    let repeats = num(6, 3.0)?.max(1.0) as usize;
    let tf = tf_for_domain(&TransferFunction::from_json(&std::fs::read_to_string(&tf_path)?)?, &domain)?;
    let ctx = GpuContext::new_headless()?;
    println!("adapter: {}", ctx.describe());
    println!("CPU: {} rayon threads", rayon::current_num_threads());
    println!("TF {tf_path}; domain {domain:?}; {n} uniform triples; best of {repeats}");
    let triples = uniform_triples(&domain, n, 0x6b61);
    let exact: Vec<[f64; 4]> = {
        let mut scratch = Vec::new();
        triples
            .iter()
            .map(|t| integrate_segment_with(&tf, t[0] as f64, t[1] as f64, t[2] as f64, &mut scratch).to_array())
            .collect()
    };
    let err = |got: &[[f32; 4]]| -> (f64, f64) {
        let (mut sum, mut max) = (0.0f64, 0.0f64);
        for (g, x) in got.iter().zip(&exact) {
            for c in 0..4 {
                let e = (g[c] as f64 - x[c]).abs();
                sum += e * e;
                max = max.max(e);
            }
        }
        ((sum / (4 * got.len()) as f64).sqrt(), max)
    };
    println!(
        "| resolution | bake | accumulation | bake ms | setup ms | RMS vs exact | max vs exact | max vs CPU table | RMS vs CPU table |"
    );
    println!("|---|---|---|---:|---:|---:|---:|---:|---:|");
    for (n_s, n_l) in [(32, 64), (64, 128), (128, 256)] {
        let params = Table3dParams { n_s, n_l, ..Table3dParams::tf_nodes() };
        let mut cpu_ms = f64::INFINITY;
        let mut cpu = None;
        for _ in 0..repeats {
            let t = Instant::now();
            let table = Table3d::build(&tf, &domain, &params)?;
            cpu_ms = cpu_ms.min(t.elapsed().as_secs_f64() * 1e3);
            cpu = Some(table);
        }
        let cpu = cpu.expect("one repeat");
        let cpu_vals: Vec<[f32; 4]> = triples.iter().map(|t| cpu.lookup(t[0], t[1], t[2])).collect();
        let (rms, max) = err(&cpu_vals);
        let res = format!("{n_s}x{n_s}x{n_l}");
        println!("| {res} | CPU | f32 | {cpu_ms:.1} | - | {rms:.2e} | {max:.2e} | - | - |");
        for acc in [GpuAccumulation::F32, GpuAccumulation::F16] {
            let (mut bake_ms, mut setup_ms) = (f64::INFINITY, f64::INFINITY);
            let mut gpu = None;
            for _ in 0..repeats {
                let g = GpuTable3d::bake(&ctx, &tf, &domain, &params, acc)?;
                bake_ms = bake_ms.min(g.stats().bake_seconds * 1e3);
                setup_ms = setup_ms.min(g.stats().setup_seconds * 1e3);
                gpu = Some(g);
            }
            let gpu = gpu.expect("one repeat");
            let shader = GpuShader::table3d_baked(&ctx, &gpu)?;
            let vals = shader.probe_table3d(&ctx, &triples)?;
            let (rms, max) = err(&vals);
            let dense = gpu.read_back(&ctx)?;
            let (mut d_max, mut d_sum, mut d_n) = (0.0f64, 0.0f64, 0usize);
            for a in 0..n_s {
                for b in 0..n_s {
                    for k in 0..n_l {
                        if let Some(c) = cpu.entry(a, b, k) {
                            let g = dense[(a * n_s + b) * n_l + k];
                            for ch in 0..4 {
                                let d = (g[ch] - c[ch]).abs() as f64;
                                d_max = d_max.max(d);
                                d_sum += d * d;
                            }
                            d_n += 4;
                        }
                    }
                }
            }
            println!(
                "| {res} | GPU | {} | {bake_ms:.1} | {setup_ms:.1} | {rms:.2e} | {max:.2e} | {d_max:.2e} | {:.2e} |",
                acc.id(),
                (d_sum / d_n.max(1) as f64).sqrt()
            );
        }
    }
    println!();
    println!("| table | bake | bake ms | setup ms | RMS vs exact | max vs exact | max diff of lookups vs CPU table |");
    println!("|---|---|---:|---:|---:|---:|---:|");
    for (degree, res) in [(1, 128), (2, 128), (4, 128), (2, 512)] {
        let p = tet_preint::PolyParams::new(degree, res, domain.s_lo, domain.s_hi, domain.len_max_world)
            .with_max_ds(domain.max_ds);
        let mut cpu_ms = f64::INFINITY;
        let mut cpu = None;
        for _ in 0..repeats {
            let t = Instant::now();
            let table = tet_preint::PolyTable::build(&tf, &p)?;
            cpu_ms = cpu_ms.min(t.elapsed().as_secs_f64() * 1e3);
            cpu = Some(table);
        }
        let cpu = cpu.expect("one repeat");
        let cpu_vals: Vec<[f32; 4]> = triples.iter().map(|t| cpu.lookup(t[0], t[1], t[2])).collect();
        let (rms, max) = err(&cpu_vals);
        println!("| poly{degree} {res}² | CPU (f64) | {cpu_ms:.1} | - | {rms:.2e} | {max:.2e} | - |");
        let (mut bake_ms, mut setup_ms) = (f64::INFINITY, f64::INFINITY);
        let mut gpu = None;
        for _ in 0..repeats {
            let (g, stats) = tet_gpu::bake_poly(&ctx, &tf, &p)?;
            bake_ms = bake_ms.min(stats.bake_seconds * 1e3);
            setup_ms = setup_ms.min(stats.setup_seconds * 1e3);
            gpu = Some(g);
        }
        let gpu = gpu.expect("one repeat");
        let vals: Vec<[f32; 4]> = triples.iter().map(|t| gpu.lookup(t[0], t[1], t[2])).collect();
        let (rms, max) = err(&vals);
        let d =
            vals.iter().zip(&cpu_vals).flat_map(|(a, b)| (0..4).map(move |c| (a[c] - b[c]).abs())).fold(0.0, f32::max);
        println!(
            "| poly{degree} {res}² | GPU (f32) | {bake_ms:.1} | {setup_ms:.1} | {rms:.2e} | {max:.2e} | {d:.2e} |"
        );
    }
    Ok(())
}
