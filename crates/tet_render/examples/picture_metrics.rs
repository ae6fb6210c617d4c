//! Measures a rendered picture the way issue 17's acceptance does: over the
//! pixels the volume covers (α above `image::COVERED_ALPHA` in the float
//! image), the luminance spread (95th − 5th percentile of luma), the share
//! of near-white pixels and the median chroma of the displayed PNG.
//!
//! `cargo run --release -p tet_render --example picture_metrics -- PICTURE.png FLOAT.npy [more pairs…]`
//!
//! The pairs are what `tetview render B -o PICTURE.png --float FLOAT.npy` writes.

use std::path::Path;
use tet_render::{Image, PictureMetrics};

fn rgba8(path: &Path) -> Result<(Vec<u8>, u32, u32), String> {
    let file = std::fs::File::open(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let mut reader =
        png::Decoder::new(std::io::BufReader::new(file)).read_info().map_err(|e| format!("{}: {e}", path.display()))?;
    let mut buf = vec![0u8; reader.output_buffer_size()];
    let info = reader.next_frame(&mut buf).map_err(|e| format!("{}: {e}", path.display()))?;
    if info.color_type != png::ColorType::Rgba || info.bit_depth != png::BitDepth::Eight {
        return Err(format!("{}: not 8-bit RGBA (tetview render writes that)", path.display()));
    }
    buf.truncate(info.buffer_size());
    Ok((buf, info.width, info.height))
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.is_empty() || !args.len().is_multiple_of(2) {
        eprintln!("usage: picture_metrics PICTURE.png FLOAT.npy [PICTURE.png FLOAT.npy …]");
        std::process::exit(2);
    }
    let mut failed = false;
    for pair in args.chunks_exact(2) {
        let (png_path, npy_path) = (Path::new(&pair[0]), Path::new(&pair[1]));
        let measured = rgba8(png_path).and_then(|(buf, w, h)| {
            let img = Image::read_npy(npy_path).map_err(|e| format!("{}: {e}", npy_path.display()))?;
            if (img.width(), img.height()) != (w, h) {
                return Err(format!(
                    "{} is {}x{}, {} is {w}x{h}",
                    npy_path.display(),
                    img.width(),
                    img.height(),
                    png_path.display()
                ));
            }
            let covered: Vec<bool> = img.pixels().iter().map(|p| p[3] > tet_render::image::COVERED_ALPHA).collect();
            Ok(PictureMetrics::of_rgba8(&buf, &covered))
        });
        match measured {
            Ok(m) => println!("{}: {m}", png_path.display()),
            Err(e) => {
                eprintln!("error: {e}");
                failed = true;
            }
        }
    }
    std::process::exit(i32::from(failed));
}
