//! Renders one bundle with a baked `.tetl` repeatedly and prints each
//! frame's stages: the loop to run under a profiler (`perf record`,
//! `valgrind --tool=callgrind` with `RAYON_NUM_THREADS=1`) or to compare
//! two builds' frame times and CPU time per fragment.
//!
//! `cargo run --release -p tet_render --example frame_profile -- B.tetb L.tetl [frames] [WxH] [azimuth] [elevation]`
//!
//! The first frame is cold (view, cull, sort); the others reuse the order.
//! `TET_TILE=16` sets the tile side; `TET_WALK_INTERLEAVE=K` walks K rays at
//! once (`RasterOptions::walk_interleave`; default `walk::WALK_LANES`); `TET_WALK_PREFETCH=0` turns the walker's
//! prefetch of the next step's records off (`RasterOptions::walk_prefetch`); `TET_WALK_PACKETS=0` walks
//! one ray a lane-step in scalar code instead of eight in AVX2 lanes (`RasterOptions::walk_packets`); `TET_GENERAL_PATH=1` turns the rasterizer's fast path off
//! (`RasterOptions::fast_path`); `TET_FRAME_NPY=out.npy` writes the last
//! frame (linear premultiplied RGBA) for `tetview diff`; `TET_ORBIT=D`
//! turns the camera D degrees of azimuth before every frame after the
//! first (each frame a camera move: re-sorted and set up again);
//! `TET_NO_KEEP=1` keeps no per-tet setup across frames. `TET_RENDERER=pt`
//! draws by projected tetrahedra instead of the ray walker (the default).
//! `TET_RECORD_SEGS=path` appends every shaded batch to a file (see `Recorder`).
//! `TET_FREE_SHADER=1` replaces the table with a shader that returns a
//! constant colour: the renderer's own cost, without lookups. `TET_VIEW=view.json`
//! starts from that camera and its size (VTK fields, e.g. the one `shared/peer/vtk_render.py`
//! records) instead of the framing orbited by azimuth/elevation; `TET_ORBIT`
//! then turns it.

use std::path::Path;
use std::sync::Arc;
use tet_bundle::Bundle;
use tet_preint::{load_shader, LutFile};
use tet_render::pipeline::process_cpu_seconds;
use tet_render::{RasterOptions, Renderer, Scene, TfCuller, ViewSpec};

/// Passes every batch to the table and appends it to a file (`TET_RECORD_SEGS`):
/// per batch its length (u32) then (Sf, Sb, l) per segment (f32, little
/// endian), the stream `tet_preint`'s `lookup_replay` example times. Run
/// with `RAYON_NUM_THREADS=1` for one ray's batches in order.
struct Recorder(Arc<dyn tet_preint::SegmentShader>, std::sync::Mutex<std::io::BufWriter<std::fs::File>>);

impl tet_preint::SegmentShader for Recorder {
    fn method(&self) -> tet_preint::Method {
        self.0.method()
    }
    fn shade(&self, s: &tet_preint::Segment) -> tet_preint::Rgba32 {
        self.0.shade(s)
    }
    fn shade_batch(&self, segs: &tet_preint::SegmentBatch, out: &mut [tet_preint::Rgba32; tet_preint::BATCH]) {
        use std::io::Write;
        let mut bytes = Vec::with_capacity(4 + 12 * segs.len);
        bytes.extend_from_slice(&(segs.len as u32).to_le_bytes());
        for i in 0..segs.len {
            for v in [segs.s_front[i], segs.s_back[i], segs.len_world[i]] {
                bytes.extend_from_slice(&v.to_le_bytes());
            }
        }
        self.1.lock().expect("recorder").write_all(&bytes).expect("segments written");
        self.0.shade_batch(segs, out)
    }
}

/// A shader whose every segment is the same faint grey: no lookup cost.
struct FreeShader(tet_preint::Method);

impl tet_preint::SegmentShader for FreeShader {
    fn method(&self) -> tet_preint::Method {
        self.0
    }
    fn shade(&self, _: &tet_preint::Segment) -> tet_preint::Rgba32 {
        [0.01, 0.01, 0.01, 0.01]
    }
    fn shade_batch(&self, segs: &tet_preint::SegmentBatch, out: &mut [tet_preint::Rgba32; tet_preint::BATCH]) {
        for o in out.iter_mut().take(segs.len) {
            *o = [0.01, 0.01, 0.01, 0.01];
        }
    }
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if args.len() < 3 {
        eprintln!("usage: frame_profile BUNDLE LUT [frames] [WxH] [azimuth] [elevation]");
        std::process::exit(2);
    }
    let bundle = Bundle::read(Path::new(&args[1])).expect("bundle reads");
    let lut_path = Path::new(&args[2]);
    let lut = LutFile::read(lut_path).expect("lut reads");
    let tf = lut.transfer_function().expect("lut's transfer function");
    let mut shader: Arc<dyn tet_preint::SegmentShader> = load_shader(&lut, lut_path).expect("shader").into();
    // (Switches are on when set to anything but "0", as TET_WALK_PREFETCH is off at "0".)
    let on = |name: &str| std::env::var(name).is_ok_and(|v| v != "0");
    if on("TET_FREE_SHADER") {
        shader = Arc::new(FreeShader(shader.method()));
    }
    if let Ok(p) = std::env::var("TET_RECORD_SEGS") {
        let f = std::fs::File::create(&p).expect("segment file created");
        shader = Arc::new(Recorder(shader, std::sync::Mutex::new(std::io::BufWriter::new(f))));
    }
    let frames: usize = args.get(3).map_or(3, |s| s.parse().expect("frames"));
    let size: [u32; 2] = args.get(4).map_or([512, 512], |s| {
        let (w, h) = s.split_once('x').expect("WxH");
        [w.parse().expect("width"), h.parse().expect("height")]
    });
    let az: f64 = args.get(5).map_or(30.0, |s| s.parse().expect("azimuth"));
    let el: f64 = args.get(6).map_or(20.0, |s| s.parse().expect("elevation"));

    let scene = Scene::from_bundle(&bundle).expect("scene");
    let (lo, hi) = scene.bounds();
    let base = match std::env::var("TET_VIEW") {
        Ok(p) => ViewSpec::from_json(&std::fs::read_to_string(&p).expect("view file reads")).expect("view JSON"),
        Err(_) => ViewSpec::framing(lo, hi, size).orbit(az, el, 1.0),
    };
    let mut r = Renderer::new(scene);
    r.set_view(&base).expect("view");
    r.set_shader(shader);
    r.set_culler(Some(Arc::new(TfCuller::new(&tf))));
    let fast_path = !on("TET_GENERAL_PATH");
    let tile = std::env::var("TET_TILE").ok().and_then(|t| t.parse().ok()).unwrap_or(RasterOptions::default().tile);
    let keep = !on("TET_NO_KEEP");
    let orbit: f64 = std::env::var("TET_ORBIT").ok().and_then(|d| d.parse().ok()).unwrap_or(0.0);
    let walk_interleave =
        std::env::var("TET_WALK_INTERLEAVE").ok().map(|k| k.parse().expect("TET_WALK_INTERLEAVE: rays"));
    let walk_prefetch = std::env::var("TET_WALK_PREFETCH").map_or(true, |v| v != "0");
    let walk_packets = std::env::var("TET_WALK_PACKETS").map_or(true, |v| v != "0");
    let walk_adaptive = std::env::var("TET_ADAPTIVE").ok().map(|k| k.parse().expect("TET_ADAPTIVE: tolerance"));
    let mut opts = RasterOptions {
        fast_path,
        tile,
        walk_interleave,
        walk_prefetch,
        walk_packets,
        walk_adaptive,
        ..Default::default()
    };
    if !keep {
        opts.setup_cache_bytes = 0;
    }
    r.set_raster_options(opts);
    let kind: tet_render::CpuRenderer =
        std::env::var("TET_RENDERER").map_or(Ok(Default::default()), |k| k.parse()).expect("TET_RENDERER: walk or pt");
    r.set_renderer(kind);
    for f in 0..frames.max(1) {
        if f > 0 && orbit != 0.0 {
            r.set_view(&base.orbit(orbit * f as f64, 0.0, 1.0)).expect("view");
        }
        let c0 = process_cpu_seconds();
        let (img, st) = r.render(&|_, _| {}).expect("render");
        if f + 1 == frames.max(1) {
            if let Ok(p) = std::env::var("TET_FRAME_NPY") {
                img.write_npy(Path::new(&p)).expect("npy written");
            }
        }
        let cpu = process_cpu_seconds() - c0;
        println!(
            "frame {f} ({}): {:.3} s (view {:.3}, cull {:.3}, sort {} {:.3}, bin {:.3}, raster {:.3}), {} tets drawn, {} fragments, {} crossings, {} rays walked ({} in packets), {} interpolated, {} runs, {} front faces, {} terminated, {} exact tests, {} setups, {}",
            st.renderer,
            st.total_seconds,
            st.view_seconds,
            st.cull_seconds,
            st.sort_method,
            st.sort_seconds,
            st.project_seconds,
            st.raster_seconds,
            st.tets_drawn,
            st.fragments,
            st.crossings,
            st.walk_rays,
            st.walk_packet_rays,
            st.walk_rays_interpolated,
            st.walk_runs,
            st.walk_front_faces,
            st.walk_terminated,
            st.walk_exact_tests,
            st.setups,
            st.throughput_summary(cpu)
        );
        if f == 0 {
            println!(
                "kept per-tet setup: {:.1} MiB; walker: {:.1} MiB ({:.1} bytes a tet)",
                r.setup_bytes() as f64 / (1 << 20) as f64,
                r.walk_bytes() as f64 / (1 << 20) as f64,
                r.walk_bytes() as f64 / st.tets_total.max(1) as f64
            );
        }
    }
}
