//! clap `value_parser`s shared by the programs: `WxH` sizes, `LO,HI`
//! ranges, `R,G,B` colours, `X,Y,Z` points and directions and `I,J,K`
//! counts. Each returns a message naming what it got and what it expects.

use tet_render::camera::MAX_IMAGE_SIDE;

/// Smallest and largest side of a `tetview view` window, in points.
pub const WINDOW_SIDE: (u32, u32) = (64, 16384);

/// An image size `WxH` (or `WXH`): two whole numbers of pixels, each
/// 1..=[`MAX_IMAGE_SIDE`] (what the renderers accept).
pub fn parse_size(s: &str) -> Result<[u32; 2], String> {
    parse_sides(s, (1, MAX_IMAGE_SIDE), "512x512")
}

/// A window size `WxH` in points, each side within [`WINDOW_SIDE`]; the
/// same syntax as [`parse_size`], as the `[f32; 2]` egui takes.
pub fn parse_window_size(s: &str) -> Result<[f32; 2], String> {
    let [w, h] = parse_sides(s, WINDOW_SIDE, "1100x720")?;
    Ok([w as f32, h as f32])
}

fn parse_sides(s: &str, (min, max): (u32, u32), example: &str) -> Result<[u32; 2], String> {
    let expected = || format!("{s:?}: expected WxH, two whole numbers {min}..={max}, e.g. {example}");
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(expected)?;
    let side = |t: &str| -> Result<u32, String> {
        let v: u64 = t.trim().parse().map_err(|_| expected())?;
        if v < u64::from(min) || v > u64::from(max) {
            return Err(format!("{s:?}: each side must be {min}..={max}, got {v}"));
        }
        Ok(v as u32)
    };
    Ok([side(w)?, side(h)?])
}

/// A range `LO,HI`: two finite numbers with LO < HI (spaces around either
/// are allowed). Flags taking it should set `allow_hyphen_values` so that a
/// negative LO is not read as a flag.
pub fn parse_range(s: &str) -> Result<(f64, f64), String> {
    let expected = || format!("{s:?}: expected LO,HI, two numbers, e.g. 0,1");
    let (a, b) = s.split_once(',').ok_or_else(expected)?;
    let number = |t: &str| t.trim().parse::<f64>().map_err(|_| expected());
    let (lo, hi) = (number(a)?, number(b)?);
    if !(lo.is_finite() && hi.is_finite()) {
        return Err(format!("{s:?}: LO and HI must be finite"));
    }
    if lo >= hi {
        return Err(format!("{s:?}: LO must be below HI"));
    }
    Ok((lo, hi))
}

/// A colour `R,G,B`: three finite numbers ≥ 0 (linear, not limited to 1;
/// spaces around each are allowed), e.g. a `--background`.
pub fn parse_rgb(s: &str) -> Result<[f32; 3], String> {
    let expected = || format!("{s:?}: expected R,G,B, three non-negative numbers, e.g. 0,0,0");
    let v: Vec<f32> =
        s.split(',').map(|x| x.trim().parse::<f32>().map_err(|_| expected())).collect::<Result<_, _>>()?;
    match v[..] {
        [r, g, b] if v.iter().all(|c| c.is_finite() && *c >= 0.0) => Ok([r, g, b]),
        [_, _, _] => Err(format!("{s:?}: each of R,G,B must be finite and ≥ 0")),
        _ => Err(expected()),
    }
}

/// A point or vector `X,Y,Z`: three finite numbers (spaces around each are
/// allowed), e.g. a raw volume's `--spacing` or `--origin`. Flags taking it
/// should set `allow_hyphen_values` so that a negative X is not read as a flag.
pub fn parse_xyz(s: &str) -> Result<[f64; 3], String> {
    let expected = || format!("{s:?}: expected X,Y,Z, three numbers, e.g. 0,0,1");
    let v: Vec<f64> =
        s.split(',').map(|x| x.trim().parse::<f64>().map_err(|_| expected())).collect::<Result<_, _>>()?;
    match v[..] {
        [x, y, z] if v.iter().all(|c| c.is_finite()) => Ok([x, y, z]),
        [_, _, _] => Err(format!("{s:?}: each of X,Y,Z must be finite")),
        _ => Err(expected()),
    }
}

/// A direction `X,Y,Z`: [`parse_xyz`], not all zero (e.g. a `--view-up`).
pub fn parse_direction(s: &str) -> Result<[f64; 3], String> {
    let v = parse_xyz(s)?;
    if v == [0.0; 3] {
        return Err(format!("{s:?}: a direction cannot be 0,0,0 (e.g. 0,0,1)"));
    }
    Ok(v)
}

/// Three whole numbers `I,J,K` (e.g. a raw volume's `--dims`), each ≥ 1.
pub fn parse_counts3(s: &str) -> Result<[usize; 3], String> {
    let expected = || format!("{s:?}: expected I,J,K, three whole numbers ≥ 1, e.g. 64,64,32");
    let v: Vec<usize> =
        s.split(',').map(|x| x.trim().parse::<usize>().map_err(|_| expected())).collect::<Result<_, _>>()?;
    match v[..] {
        [i, j, k] if i >= 1 && j >= 1 && k >= 1 => Ok([i, j, k]),
        _ => Err(expected()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn points_directions_and_counts_take_three_values() {
        assert_eq!(parse_xyz(" -1.5, 0 ,2e3"), Ok([-1.5, 0.0, 2000.0]));
        assert_eq!(parse_direction("0,0,1"), Ok([0.0, 0.0, 1.0]));
        assert_eq!(parse_counts3("64, 64,32"), Ok([64, 64, 32]));
        for bad in ["", "1,2", "1,2,3,4", "a,b,c", "1,,2", "1;2;3", "nan,0,0", "0,inf,0"] {
            let e = parse_xyz(bad).unwrap_err();
            assert!(e.starts_with(&format!("{bad:?}: ")), "{bad:?}: {e}");
            assert!(parse_direction(bad).is_err(), "{bad:?}");
        }
        assert!(parse_xyz("nan,0,0").unwrap_err().contains("finite"));
        assert!(parse_direction("0,0,0").unwrap_err().contains("cannot be 0,0,0"));
        for bad in ["", "1,2", "0,4,4", "-1,2,3", "1.5,2,3", "1,2,3,4"] {
            assert!(parse_counts3(bad).unwrap_err().contains("expected I,J,K"), "{bad:?}");
        }
    }

    #[test]
    fn sizes_parse_within_their_bounds() {
        assert_eq!(parse_size("512x256"), Ok([512, 256]));
        assert_eq!(parse_size(" 1X1 "), Ok([1, 1]));
        assert_eq!(parse_size(&format!("{MAX_IMAGE_SIDE}x2")), Ok([MAX_IMAGE_SIDE, 2]));
        assert_eq!(parse_window_size("1100x720"), Ok([1100.0, 720.0]));
    }

    #[test]
    fn bad_sizes_say_what_is_wrong() {
        for bad in ["", "512", "512x", "x512", "ax2", "2x2x2", "-1x5", "1.5x2", "99999999999x2"] {
            let e = parse_size(bad).unwrap_err();
            assert!(e.contains("expected WxH") || e.contains("each side"), "{bad:?}: {e}");
        }
        assert!(parse_size("0x10").unwrap_err().contains("each side must be 1..="));
        assert!(parse_size(&format!("{}x10", MAX_IMAGE_SIDE + 1)).unwrap_err().contains("each side"));
        assert!(parse_window_size("32x720").unwrap_err().contains("64..=16384"));
    }

    #[test]
    fn ranges_are_finite_and_increasing() {
        assert_eq!(parse_range("0,1"), Ok((0.0, 1.0)));
        assert_eq!(parse_range(" -5 , 2.5e3 "), Ok((-5.0, 2500.0)));
        for bad in ["", "1", "1,", ",1", "a,b", "1,2,3", "nan,1", "0,inf", "1,1", "2,1"] {
            assert!(parse_range(bad).is_err(), "{bad:?} parsed");
        }
        assert!(parse_range("2,1").unwrap_err().contains("below"));
        assert!(parse_range("0,inf").unwrap_err().contains("finite"));
    }

    #[test]
    fn colours_need_three_finite_non_negative_numbers() {
        assert_eq!(parse_rgb("0,0,0"), Ok([0.0, 0.0, 0.0]));
        assert_eq!(parse_rgb(" 1, 0.5 ,2 "), Ok([1.0, 0.5, 2.0]));
        for bad in ["", "1,2", "1,2,3,4", "a,b,c", "1,,2", "1;2;3", "-1,0,0", "0,inf,0", "NaN,0,0"] {
            let e = parse_rgb(bad).unwrap_err();
            assert!(e.starts_with(&format!("{bad:?}: ")), "{bad:?}: {e}");
        }
        assert!(parse_rgb("-1,0,0").unwrap_err().contains("≥ 0"));
        assert!(parse_rgb("1,2").unwrap_err().contains("expected R,G,B"));
    }
}
