//! `tetlut show`: a `.tetl`'s tables as one labelled PNG.

use std::path::PathBuf;

use anyhow::Result;
use tet_plot::canvas::{BLACK, GREY};
use tet_plot::{fmt_num, viridis, Canvas, Rgb};
use tet_preint::{Baked, LutFile};

use tet_cli::{fail, ExitKind, KindExt};

#[derive(Debug, clap::Args)]
pub struct ShowArgs {
    /// The .tetl to draw.
    pub lut: PathBuf,
    /// Output PNG.
    #[arg(short, long)]
    pub output: PathBuf,
    /// table3d: number of l-slices drawn (evenly spaced, l = 0 left out).
    #[arg(long, default_value_t = 8)]
    pub slices: usize,
}

/// One labelled image, RGB in [0, 1], row 0 at the top.
struct Tile {
    w: usize,
    h: usize,
    rgb: Vec<[f32; 3]>,
    label: String,
}

impl Tile {
    /// From a row-major image whose row 0 is the lowest value of the
    /// vertical axis (drawn at the bottom).
    fn flipped(w: usize, h: usize, rgb: Vec<[f32; 3]>, label: String) -> Tile {
        let mut out = Vec::with_capacity(rgb.len());
        for y in (0..h).rev() {
            out.extend_from_slice(&rgb[y * w..(y + 1) * w]);
        }
        Tile { w, h, rgb: out, label }
    }
}

fn to_u8(v: f32) -> u8 {
    (v.clamp(0.0, 1.0) * 255.0).round() as u8
}

fn grey(v: f32) -> [f32; 3] {
    [v, v, v]
}

fn vir(v: f32) -> [f32; 3] {
    let c: Rgb = viridis(f64::from(v.clamp(0.0, 1.0)));
    c.map(|x| x as f32 / 255.0)
}

fn max_of<'a>(it: impl Iterator<Item = &'a f32>) -> f32 {
    let m = it.fold(0.0f32, |m, v| m.max(v.abs()));
    if m > 0.0 && m.is_finite() {
        m
    } else {
        1.0
    }
}

/// Lays out rows of tiles under a title, each tile scaled by one integer
/// factor (or sampled down) so its longer side is near `target` pixels.
fn compose(title: &str, notes: &[String], rows: &[Vec<Tile>], target: usize) -> Canvas {
    let fit = |t: &Tile| -> (usize, usize) {
        let m = t.w.max(t.h);
        if m >= target {
            let f = m.div_ceil(target);
            (t.w.div_ceil(f), t.h.div_ceil(f))
        } else {
            let f = (target / m).max(1);
            (t.w * f, t.h * f)
        }
    };
    let pad = 12;
    let label_h = 14;
    let header = 28 + 12 * notes.len();
    let mut width = 0;
    let mut height = header;
    for row in rows {
        let w: usize = row.iter().map(|t| fit(t).0 + pad).sum::<usize>() + pad;
        width = width.max(w);
        height += row.iter().map(|t| fit(t).1).max().unwrap_or(0) + label_h + pad;
    }
    width = width
        .max(Canvas::text_width(title, 2) + 2 * pad)
        .max(notes.iter().map(|n| Canvas::text_width(n, 1) + 2 * pad).max().unwrap_or(0));
    let mut c = Canvas::new(width, height + pad);
    c.text(pad, 8, title, 2, BLACK);
    for (i, n) in notes.iter().enumerate() {
        c.text(pad, 28 + 12 * i, n, 1, GREY);
    }
    let mut y = header;
    for row in rows {
        let mut x = pad;
        let row_h = row.iter().map(|t| fit(t).1).max().unwrap_or(0);
        for t in row {
            let (w, h) = fit(t);
            c.text(x, y, &t.label, 1, BLACK);
            for py in 0..h {
                let sy = (py * t.h / h).min(t.h - 1);
                for px in 0..w {
                    let sx = (px * t.w / w).min(t.w - 1);
                    let v = t.rgb[sy * t.w + sx];
                    c.set(x + px, y + label_h + py, [to_u8(v[0]), to_u8(v[1]), to_u8(v[2])]);
                }
            }
            c.frame(x.saturating_sub(1), y + label_h - 1, w + 2, h + 2, GREY);
            x += w + pad;
        }
        y += row_h + label_h + pad;
    }
    c
}

pub fn run(args: &ShowArgs) -> Result<()> {
    let lut = LutFile::read(&args.lut).map_err(anyhow::Error::new).kind(ExitKind::Input)?;
    let baked = Baked::from_lut(&lut, &args.lut).map_err(anyhow::Error::new).kind(ExitKind::Input)?;
    let name = args.lut.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let d = lut.header.domain;
    let dom = d.map_or(String::new(), |d| {
        format!(
            "s in [{}, {}], |Sf-Sb| <= {}, l <= {}",
            fmt_num(d.s_lo),
            fmt_num(d.s_hi),
            fmt_num(d.max_ds),
            fmt_num(d.len_max_world)
        )
    });
    let canvas = match &baked {
        Baked::Table3d(t) => {
            let p = t.params();
            let n = p.n_s;
            let k_count = args.slices.clamp(1, p.n_l - 1);
            let ks: Vec<usize> = (0..k_count).map(|i| 1 + i * (p.n_l - 2) / (k_count - 1).max(1)).collect();
            let slices: Vec<Vec<[f32; 4]>> = ks.iter().map(|&k| t.slice_image(k)).collect();
            let gain = max_of(slices.iter().flatten().flat_map(|e| e[..3].iter()));
            let colour = ks
                .iter()
                .zip(&slices)
                .map(|(&k, s)| {
                    let rgb = s.iter().map(|e| [e[0] / gain, e[1] / gain, e[2] / gain]).collect();
                    Tile::flipped(n, n, rgb, format!("l = {}", fmt_num(t.len_at(k))))
                })
                .collect();
            let alpha = ks
                .iter()
                .zip(&slices)
                .map(|(&k, s)| Tile::flipped(n, n, s.iter().map(|e| grey(e[3])).collect(), format!("alpha, k = {k}")))
                .collect();
            compose(
                &format!("{name}: table3d {}x{}x{} {}", n, n, p.n_l, p.precision),
                &[
                    format!("{dom}; band half-width {} samples", t.band_half_width()),
                    format!(
                        "l-slices: x = Sf, y = Sb (up); top: premultiplied colour / {} (max), bottom: alpha; black outside the band",
                        fmt_num(f64::from(gain))
                    ),
                ],
                &[colour, alpha],
                160,
            )
        }
        Baked::Atlas2d(a) => {
            let (w, h) = a.image_size();
            let img = a.image();
            let gain = max_of(img.iter().flat_map(|e| e[..3].iter()));
            let p = a.params();
            let colour = Tile {
                w,
                h,
                rgb: img.iter().map(|e| [e[0] / gain, e[1] / gain, e[2] / gain]).collect(),
                label: "premultiplied colour".into(),
            };
            let alpha = Tile { w, h, rgb: img.iter().map(|e| grey(e[3])).collect(), label: "alpha".into() };
            compose(
                &format!("{name}: atlas2d, {} planes of {}^2 {}", p.planes, p.res, p.precision),
                &[
                    dom,
                    format!(
                        "plane p (pseudo-angle p/(P-1)) is tile (p mod cols, p div cols), read left to right, top to bottom; colour / {}",
                        fmt_num(f64::from(gain))
                    ),
                ],
                &[vec![colour, alpha]],
                720,
            )
        }
        Baked::Partial(s) => {
            let psi = s.psi();
            let r = psi.params().res;
            let data = psi.storage().to_f32();
            let ch = psi.storage().channels();
            let mut tiles = vec![];
            for (c, label) in [(0, "Psi"), (1, "Psi_1")].into_iter().take(ch) {
                let v: Vec<f32> = (0..r * r).map(|i| data[i * ch + c]).collect();
                let m = max_of(v.iter());
                tiles.push(Tile::flipped(
                    r,
                    r,
                    v.iter().map(|x| vir(x / m)).collect(),
                    format!("{label} (viridis, 0..{})", fmt_num(f64::from(m))),
                ));
            }
            compose(
                &format!("{name}: partial, Psi {r}^2 {}", psi.params().precision),
                &["x = gamma_front, y = gamma_back (up), gamma = rate / (1 + rate); TF-independent".into()],
                &[tiles],
                384,
            )
        }
        Baked::Poly(t, precision) => {
            let n = t.res();
            let row = t.row_len();
            let stride = 3 * (t.degree() + 1);
            // Expand the band to the square (black outside).
            let col_of = |i: usize, j: usize| -> Option<usize> {
                match t.band() {
                    None => Some(j),
                    Some(b) => (i.abs_diff(j) <= b).then(|| j + b - i),
                }
            };
            let square = |f: &dyn Fn(usize) -> [f32; 3]| -> Vec<[f32; 3]> {
                let mut out = vec![[0.0; 3]; n * n];
                for i in 0..n {
                    for j in 0..n {
                        if let Some(c) = col_of(i, j) {
                            // Image row = Sb (j), column = Sf (i).
                            out[j * n + i] = f(i * row + c);
                        }
                    }
                }
                out
            };
            let rho_max = max_of(t.rho().iter());
            let mut tiles = vec![Tile::flipped(
                n,
                n,
                square(&|e| vir(t.rho()[e] / rho_max)),
                format!("rho^ (viridis, 0..{})", fmt_num(f64::from(rho_max))),
            )];
            for r in 0..=t.degree() {
                let vals = (0..t.rho().len()).flat_map(|e| t.coef()[e * stride + 3 * r..e * stride + 3 * r + 3].iter());
                let m = max_of(vals);
                let f = |e: usize| -> [f32; 3] {
                    let c = &t.coef()[e * stride + 3 * r..e * stride + 3 * r + 3];
                    if r == 0 {
                        [c[0] / m, c[1] / m, c[2] / m]
                    } else {
                        [0.5 + 0.5 * c[0] / m, 0.5 + 0.5 * c[1] / m, 0.5 + 0.5 * c[2] / m]
                    }
                };
                let label = if r == 0 {
                    format!("C~0 / {}", fmt_num(f64::from(m)))
                } else {
                    format!("C~{r}: 0.5 + C/{}", fmt_num(f64::from(2.0 * m)))
                };
                tiles.push(Tile::flipped(n, n, square(&f), label));
            }
            compose(
                &format!("{name}: poly{} {n}^2 {precision}", t.degree()),
                &[
                    dom,
                    "x = Sf, y = Sb (up); colour(l) = w * sum C~i (l/l_max)^i; grey = 0 for i >= 1; black outside the band"
                        .into(),
                ],
                &[tiles],
                256,
            )
        }
        Baked::BivApprox(s, precision) => {
            let t = s.table();
            let r = t.res();
            let mk = |v: &[f32], label: &str| {
                let m = max_of(v.iter());
                // Stored row-major in alpha_f: transpose so x = alpha_f.
                let img: Vec<[f32; 3]> = (0..r * r).map(|k| vir(v[(k % r) * r + k / r] / m)).collect();
                Tile::flipped(r, r, img, format!("{label} (viridis, 0..{})", fmt_num(f64::from(m))))
            };
            compose(
                &format!("{name}: biv-approx F/B {r}^2 {precision}, k = {}", s.subsegments()),
                &["x = alpha_f, y = alpha_b (up) of one sub-segment; C = kf F + kb B".into()],
                &[vec![mk(t.f(), "F"), mk(t.b(), "B")]],
                384,
            )
        }
        other => {
            return Err(fail(
                ExitKind::Input,
                format!(
                    "{}: method {} tabulates nothing (the file holds only the transfer function)",
                    args.lut.display(),
                    other.method()
                ),
            ))
        }
    };
    canvas.write_png(&args.output).map_err(anyhow::Error::new).kind(ExitKind::Output)?;
    println!("wrote {} ({}x{})", args.output.display(), canvas.w, canvas.h);
    match &lut.header.certificate {
        Some(c) => println!("error {}", c.summary()),
        None if lut.header.method == "table3d" => println!("error not measured (no certificate in the file)"),
        None => {}
    }
    Ok(())
}
