//! The shading floor of a frame: renders one bundle once, records every
//! fragment's segment, then times only the table lookups of those segments
//! (the same `shade_batch` calls the rasterizer makes, on all threads) for
//! each `.tetl` given. No rasterizer can draw that frame faster than its
//! lookups take, so `drawn tets / lookup time` bounds the frame's tets/s
//! from above for that table on this machine.
//!
//! `cargo run --release -p tet_render --example shade_floor -- B.tetb L.tetl [L2.tetl ...]`
//!
//! The frame is the `frame_profile` view (512², azimuth 30°, elevation 20°,
//! the TF culler of the first table). `TET_SIZE=WxH` changes the size.

use rayon::prelude::*;
use std::path::Path;
use std::sync::{Arc, Mutex};
use tet_bundle::Bundle;
use tet_preint::{load_shader, LutFile, Method, Rgba32, Segment, SegmentBatch, SegmentShader, BATCH};
use tet_render::{Renderer, Scene, TfCuller, ViewSpec};

/// Passes every call through to `inner` and keeps a copy of each batch.
struct Recorder {
    inner: Arc<dyn SegmentShader>,
    batches: Mutex<Vec<SegmentBatch>>,
}

impl SegmentShader for Recorder {
    fn method(&self) -> Method {
        self.inner.method()
    }
    fn shade(&self, seg: &Segment) -> Rgba32 {
        self.inner.shade(seg)
    }
    fn shade_batch(&self, segs: &SegmentBatch, out: &mut [Rgba32; BATCH]) {
        self.batches.lock().expect("recorder lock").push(segs.clone());
        self.inner.shade_batch(segs, out);
    }
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if args.len() < 3 {
        eprintln!("usage: shade_floor BUNDLE LUT [LUT ...]");
        std::process::exit(2);
    }
    let size: [u32; 2] = std::env::var("TET_SIZE").ok().map_or([512, 512], |s| {
        let (w, h) = s.split_once('x').expect("WxH");
        [w.parse().expect("width"), h.parse().expect("height")]
    });
    let bundle = Bundle::read(Path::new(&args[1])).expect("bundle reads");
    let first = LutFile::read(Path::new(&args[2])).expect("lut reads");
    let tf = first.transfer_function().expect("lut's transfer function");
    let inner: Arc<dyn SegmentShader> = load_shader(&first, Path::new(&args[2])).expect("shader").into();
    let recorder = Arc::new(Recorder { inner, batches: Mutex::new(Vec::new()) });

    let scene = Scene::from_bundle(&bundle).expect("scene");
    let (lo, hi) = scene.bounds();
    let mut r = Renderer::new(scene);
    r.set_view(&ViewSpec::framing(lo, hi, size).orbit(30.0, 20.0, 1.0)).expect("view");
    r.set_shader(recorder.clone());
    r.set_culler(Some(Arc::new(TfCuller::new(&tf))));
    let (_, st) = r.render(&|_, _| {}).expect("render");
    let batches = std::mem::take(&mut *recorder.batches.lock().expect("recorder lock"));
    let shaded: usize = batches.iter().map(|b| b.len).sum();
    println!(
        "frame: {} tets drawn, {} fragments composited, {} segments shaded in {} batches, full frame {:.3} s on {} threads",
        st.tets_drawn,
        st.fragments,
        shaded,
        batches.len(),
        st.total_seconds,
        rayon::current_num_threads()
    );

    for lut_arg in &args[2..] {
        let lut = LutFile::read(Path::new(lut_arg)).expect("lut reads");
        let shader: Arc<dyn SegmentShader> = load_shader(&lut, Path::new(lut_arg)).expect("shader").into();
        let mut best = f64::INFINITY;
        let mut checksum = 0.0f64;
        for _ in 0..5 {
            let t0 = std::time::Instant::now();
            checksum = batches
                .par_chunks(64)
                .map(|chunk| {
                    let mut out = [[0.0f32; 4]; BATCH];
                    let mut acc = 0.0f32;
                    for b in chunk {
                        shader.shade_batch(b, &mut out);
                        acc += out[..b.len].iter().map(|c| c[3]).sum::<f32>();
                    }
                    acc as f64
                })
                .sum();
            best = best.min(t0.elapsed().as_secs_f64());
        }
        println!(
            "{lut_arg} ({}): lookups only {:.3} s = {:.1} ns/segment; at most {:.2} M drawn tets/s (α sum {checksum:.3e})",
            shader.method().id(),
            best,
            best * 1e9 / shaded.max(1) as f64,
            st.tets_drawn as f64 / best / 1e6
        );
    }
}
