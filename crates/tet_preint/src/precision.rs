//! Storage precision of table entries (f32, f16, unorm16, unorm8) and the
//! emulated accumulation precision of Röttger & Ertl's (2002) frame-buffer integration.
//!
//! Unorm storage needs a range: each channel c is stored as
//! round(x / scale[c] · (2^b − 1)) with `scale[c]` the channel's largest
//! value in the table (alpha's is 1), so colours above 1 survive.

use serde::{Deserialize, Serialize};
use std::fmt;
use std::str::FromStr;

/// How table entries are stored.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Precision {
    #[default]
    F32,
    F16,
    Unorm16,
    Unorm8,
}

impl Precision {
    pub const ALL: [Precision; 4] = [Precision::F32, Precision::F16, Precision::Unorm16, Precision::Unorm8];

    /// Bytes per stored channel.
    pub fn bytes(self) -> usize {
        match self {
            Precision::F32 => 4,
            Precision::F16 | Precision::Unorm16 => 2,
            Precision::Unorm8 => 1,
        }
    }

    /// The id used on command lines and in `.tetl` headers.
    pub fn id(self) -> &'static str {
        match self {
            Precision::F32 => "f32",
            Precision::F16 => "f16",
            Precision::Unorm16 => "unorm16",
            Precision::Unorm8 => "unorm8",
        }
    }
}

impl fmt::Display for Precision {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.id())
    }
}

impl FromStr for Precision {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        Precision::ALL
            .into_iter()
            .find(|p| p.id() == s)
            .ok_or_else(|| format!("unknown precision '{s}'; known: f32, f16, unorm16, unorm8"))
    }
}

/// IEEE binary16 bits of `x` (round to nearest even; overflow to ±inf).
pub fn f32_to_f16(x: f32) -> u16 {
    half::f16::from_f32(x).to_bits()
}

/// The f32 value of binary16 bits.
pub fn f16_to_f32(bits: u16) -> f32 {
    half::f16::from_bits(bits).to_f32()
}

/// Table entries in one storage precision, `channels` values per entry.
#[derive(Debug, Clone, PartialEq)]
pub struct Storage {
    precision: Precision,
    channels: usize,
    /// Per-channel range for unorm storage (1 for float storage).
    scale: Vec<f32>,
    data: Data,
}

/// A [`Storage`]'s values as stored ([`Storage::raw`]). Unorm values decode
/// as `v as f32 * factor[c]`, c the value's index modulo the channel count
/// (`factor[c] = scale[c] / (2^b − 1)`, the f32 [`Storage::get`] multiplies by).
#[derive(Debug, Clone, Copy)]
#[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
pub(crate) enum RawData<'a> {
    F32(&'a [f32]),
    /// IEEE binary16 bits.
    F16(&'a [u16]),
    Unorm16(&'a [u16], [f32; 4]),
    Unorm8(&'a [u8], [f32; 4]),
}

#[derive(Debug, Clone, PartialEq)]
enum Data {
    F32(Vec<f32>),
    U16(Vec<u16>),
    U8(Vec<u8>),
}

impl Storage {
    /// Encodes f32 `values` (interleaved, `channels` per entry; negative and
    /// NaN values are stored as 0 in unorm formats).
    pub fn encode(values: Vec<f32>, channels: usize, precision: Precision) -> Storage {
        assert!(channels > 0 && values.len().is_multiple_of(channels), "values must hold whole entries");
        let mut scale = vec![1.0f32; channels];
        if matches!(precision, Precision::Unorm16 | Precision::Unorm8) {
            scale.iter_mut().for_each(|s| *s = 0.0);
            for e in values.chunks_exact(channels) {
                for (s, &v) in scale.iter_mut().zip(e) {
                    *s = s.max(v);
                }
            }
            scale.iter_mut().for_each(|s| {
                if !(*s > 0.0 && s.is_finite()) {
                    *s = 1.0
                }
            });
        }
        let unorm = |max: f32| {
            let scale = &scale;
            move |(i, &v): (usize, &f32)| (v.max(0.0) / scale[i % channels] * max).round().min(max)
        };
        let data = match precision {
            Precision::F32 => Data::F32(values),
            Precision::F16 => Data::U16(values.iter().map(|&v| f32_to_f16(v)).collect()),
            Precision::Unorm16 => Data::U16(values.iter().enumerate().map(unorm(65535.0)).map(|q| q as u16).collect()),
            Precision::Unorm8 => Data::U8(values.iter().enumerate().map(unorm(255.0)).map(|q| q as u8).collect()),
        };
        Storage { precision, channels, scale, data }
    }

    pub fn precision(&self) -> Precision {
        self.precision
    }
    pub fn channels(&self) -> usize {
        self.channels
    }
    /// Per-channel unorm range (all 1 for float storage).
    pub fn scale(&self) -> &[f32] {
        &self.scale
    }
    /// Number of stored values (entries × channels).
    pub fn len(&self) -> usize {
        match &self.data {
            Data::F32(v) => v.len(),
            Data::U16(v) => v.len(),
            Data::U8(v) => v.len(),
        }
    }
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
    /// Bytes of stored data.
    pub fn memory_bytes(&self) -> usize {
        self.len() * self.precision.bytes()
    }

    /// The f32 values as a vector, mutable (in-place updates such as
    /// `Table3d::rebake`; resizable: a re-bake on a new band).
    pub(crate) fn f32_vec_mut(&mut self) -> Option<&mut Vec<f32>> {
        match &mut self.data {
            Data::F32(v) => Some(v),
            _ => None,
        }
    }

    /// The values themselves when stored as f32 (no decoding needed), so a
    /// hot loop can index them directly.
    pub fn as_f32(&self) -> Option<&[f32]> {
        match &self.data {
            Data::F32(v) => Some(v),
            _ => None,
        }
    }

    /// The stored values with what decoding them needs, for kernels that
    /// decode many at once (table3d's AVX2 lookup): the same decoding as
    /// [`Storage::get`], factor by factor.
    #[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
    pub(crate) fn raw(&self) -> RawData<'_> {
        let factors = |max: f32| std::array::from_fn(|c| self.scale[c % self.channels] / max);
        match (&self.data, self.precision) {
            (Data::F32(v), _) => RawData::F32(v),
            (Data::U16(v), Precision::F16) => RawData::F16(v),
            (Data::U16(v), _) => RawData::Unorm16(v, factors(65535.0)),
            (Data::U8(v), _) => RawData::Unorm8(v, factors(255.0)),
        }
    }

    /// Value `i` (entry · channels + channel), decoded.
    #[inline]
    pub fn get(&self, i: usize) -> f32 {
        let c = i % self.channels;
        match (&self.data, self.precision) {
            (Data::F32(v), _) => v[i],
            (Data::U16(v), Precision::F16) => f16_to_f32(v[i]),
            (Data::U16(v), _) => v[i] as f32 * (self.scale[c] / 65535.0),
            (Data::U8(v), _) => v[i] as f32 * (self.scale[c] / 255.0),
        }
    }

    /// Four consecutive values starting at `i` (one RGBA entry when
    /// `channels` is 4 and `i` a multiple of 4).
    #[inline]
    pub fn get4(&self, i: usize) -> [f32; 4] {
        match (&self.data, self.precision) {
            (Data::F32(v), _) => [v[i], v[i + 1], v[i + 2], v[i + 3]],
            (Data::U16(v), Precision::F16) => std::array::from_fn(|k| f16_to_f32(v[i + k])),
            (Data::U16(v), _) => {
                std::array::from_fn(|k| v[i + k] as f32 * (self.scale[(i + k) % self.channels] / 65535.0))
            }
            (Data::U8(v), _) => {
                std::array::from_fn(|k| v[i + k] as f32 * (self.scale[(i + k) % self.channels] / 255.0))
            }
        }
    }

    /// All values decoded to f32.
    pub fn to_f32(&self) -> Vec<f32> {
        (0..self.len()).map(|i| self.get(i)).collect()
    }

    /// Little-endian bytes of the stored values (the `.tetl` payload).
    pub fn to_le_bytes(&self) -> Vec<u8> {
        match &self.data {
            Data::F32(v) => v.iter().flat_map(|x| x.to_le_bytes()).collect(),
            Data::U16(v) => v.iter().flat_map(|x| x.to_le_bytes()).collect(),
            Data::U8(v) => v.clone(),
        }
    }

    /// Decodes a payload written by [`Storage::to_le_bytes`]; `None` when the
    /// byte count is not `count` values or the scale does not fit.
    pub fn from_le_bytes(
        bytes: &[u8],
        count: usize,
        channels: usize,
        precision: Precision,
        scale: Vec<f32>,
    ) -> Option<Storage> {
        if channels == 0 || scale.len() != channels || !count.is_multiple_of(channels) {
            return None;
        }
        if bytes.len() != count.checked_mul(precision.bytes())? {
            return None;
        }
        if scale.iter().any(|s| !(s.is_finite() && *s > 0.0)) {
            return None;
        }
        let data = match precision {
            Precision::F32 => {
                Data::F32(bytes.chunks_exact(4).map(|c| f32::from_le_bytes(c.try_into().expect("4 bytes"))).collect())
            }
            Precision::F16 | Precision::Unorm16 => {
                Data::U16(bytes.chunks_exact(2).map(|c| u16::from_le_bytes(c.try_into().expect("2 bytes"))).collect())
            }
            Precision::Unorm8 => Data::U8(bytes.to_vec()),
        };
        Some(Storage { precision, channels, scale, data })
    }
}

/// Precision of the running sums in Röttger & Ertl's (2002) slice-parallel integration
/// (its frame buffer): after every blending step the accumulated colour and
/// transparency are rounded to `bits`-bit unorm; 32 means plain f32.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct Accumulation {
    pub bits: u8,
}

impl Accumulation {
    pub const F32: Accumulation = Accumulation { bits: 32 };

    /// `bits` between 2 and 24 quantize; 32 is f32. Anything else is `None`.
    pub fn new(bits: u8) -> Option<Accumulation> {
        ((2..=24).contains(&bits) || bits == 32).then_some(Accumulation { bits })
    }

    /// `x` rounded to the accumulation grid (values in [0, 1]; clamped).
    #[inline]
    pub fn quantize(self, x: f32) -> f32 {
        if self.bits == 32 {
            return x;
        }
        let max = ((1u32 << self.bits) - 1) as f32;
        (x.clamp(0.0, 1.0) * max).round() / max
    }
}

impl Default for Accumulation {
    fn default() -> Self {
        Accumulation::F32
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn f16_round_trip_and_rounding() {
        for x in [0.0f32, 1.0, 0.5, 65504.0, 1e-5, 0.333_333] {
            let y = f16_to_f32(f32_to_f16(x));
            assert!((y - x).abs() <= x.abs() * 1e-3 + 1e-7, "{x} -> {y}");
        }
        assert_eq!(f32_to_f16(1.0), 0x3c00);
        assert!(f16_to_f32(f32_to_f16(1e6)).is_infinite());
    }

    #[test]
    fn storage_errors_are_within_half_a_step() {
        let vals: Vec<f32> =
            (0..400).map(|i| (i as f32 * 0.37).sin().abs() * if i % 4 == 0 { 2.0 } else { 1.0 }).collect();
        for p in Precision::ALL {
            let s = Storage::encode(vals.clone(), 4, p);
            assert_eq!(s.memory_bytes(), vals.len() * p.bytes());
            let tol = match p {
                Precision::F32 => 0.0,
                Precision::F16 => 2.0 * 2f32.powi(-11),
                Precision::Unorm16 => 2.0 * 0.5 / 65535.0 + 1e-7,
                Precision::Unorm8 => 2.0 * 0.5 / 255.0 + 1e-7,
            };
            for (i, &v) in vals.iter().enumerate() {
                assert!((s.get(i) - v).abs() <= tol, "{p} {i}: {} vs {v}", s.get(i));
            }
            let back = Storage::from_le_bytes(&s.to_le_bytes(), vals.len(), 4, p, s.scale().to_vec()).unwrap();
            assert_eq!(back, s);
        }
        assert!(Storage::from_le_bytes(&[0u8; 7], 2, 1, Precision::F32, vec![1.0]).is_none());
    }

    #[test]
    fn accumulation_quantizes() {
        assert_eq!(Accumulation::F32.quantize(0.123_456_7), 0.123_456_7);
        let a8 = Accumulation::new(8).unwrap();
        assert_eq!(a8.quantize(0.5), 128.0 / 255.0);
        assert_eq!(a8.quantize(2.0), 1.0);
        assert!(Accumulation::new(40).is_none());
    }
}
