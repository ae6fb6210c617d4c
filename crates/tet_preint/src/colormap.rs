//! Named colour maps for transfer functions: the standard perceptual maps
//! by their published control points, sampled at 17 evenly spaced points
//! (every 16th of the 256 entries, and the last).
//!
//! Sources:
//! - viridis, magma, inferno, plasma — Nathaniel Smith, Stéfan van der Walt
//!   and Eric Firing, "A better default colormap for Matplotlib", 2015;
//!   the 256-entry tables of matplotlib's `_cm_listed.py` (CC0).
//! - turbo — Anton Mikhailov, "Turbo, an improved rainbow colormap for
//!   visualization", Google AI blog, 2019; the 256-entry table of
//!   matplotlib's `_cm_listed.py` (Apache-2.0).
//! - cool-to-warm — Kenneth Moreland, "Diverging Color Maps for Scientific
//!   Visualization", 2009: endpoints (0.230, 0.299, 0.754) and
//!   (0.706, 0.016, 0.150) interpolated in Moreland's Msh space with the
//!   white midpoint of his paper (ParaView's "Cool to Warm").
//! - grayscale — black to white.
//!
//! Values are the maps' display RGB in [0, 1], used as TF colours as they
//! are (as ParaView does).

use crate::tf::{ColorNode, TransferFunction};
use crate::TfError;

/// A named colour map (see the module docs for sources).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum Colormap {
    #[default]
    Viridis,
    Inferno,
    Magma,
    Plasma,
    CoolToWarm,
    Turbo,
    Grayscale,
}

impl Colormap {
    /// Every map, in the order `--colormap` lists them.
    pub const ALL: [Colormap; 7] = [
        Colormap::Viridis,
        Colormap::Inferno,
        Colormap::Magma,
        Colormap::Plasma,
        Colormap::CoolToWarm,
        Colormap::Turbo,
        Colormap::Grayscale,
    ];

    /// The name `--colormap` takes.
    pub fn name(self) -> &'static str {
        match self {
            Colormap::Viridis => "viridis",
            Colormap::Inferno => "inferno",
            Colormap::Magma => "magma",
            Colormap::Plasma => "plasma",
            Colormap::CoolToWarm => "cool-to-warm",
            Colormap::Turbo => "turbo",
            Colormap::Grayscale => "grayscale",
        }
    }

    /// Control points, evenly spaced over [0, 1].
    pub fn control_points(self) -> &'static [[f64; 3]] {
        match self {
            Colormap::Viridis => &VIRIDIS,
            Colormap::Inferno => &INFERNO,
            Colormap::Magma => &MAGMA,
            Colormap::Plasma => &PLASMA,
            Colormap::CoolToWarm => &COOL_TO_WARM,
            Colormap::Turbo => &TURBO,
            Colormap::Grayscale => &[[0.0; 3], [1.0; 3]],
        }
    }

    /// The colour at `t` ∈ [0, 1] (clamped; NaN gives the first colour),
    /// linear between control points.
    pub fn sample(self, t: f64) -> [f64; 3] {
        let c = self.control_points();
        let x = if t.is_nan() { 0.0 } else { t.clamp(0.0, 1.0) * (c.len() - 1) as f64 };
        let i = (x.floor() as usize).min(c.len() - 2);
        let f = x - i as f64;
        [0, 1, 2].map(|k| c[i][k] * (1.0 - f) + c[i + 1][k] * f)
    }

    /// Colour nodes spreading the map's control points over [lo, hi]
    /// (one node at lo when the span is empty).
    pub fn nodes(self, lo: f64, hi: f64) -> Vec<ColorNode> {
        let c = self.control_points();
        if hi.is_nan() || lo.is_nan() || hi <= lo {
            return vec![ColorNode { x: lo, rgb: self.sample(0.5) }];
        }
        let n = c.len() - 1;
        c.iter().enumerate().map(|(i, &rgb)| ColorNode { x: lo + (hi - lo) * i as f64 / n as f64, rgb }).collect()
    }
}

impl std::fmt::Display for Colormap {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for Colormap {
    type Err = TfError;
    fn from_str(s: &str) -> Result<Colormap, TfError> {
        let key = s.trim().to_ascii_lowercase().replace('_', "-");
        let alias = match key.as_str() {
            "coolwarm" | "cool-warm" => "cool-to-warm",
            "gray" | "grey" | "greyscale" => "grayscale",
            other => other,
        };
        Colormap::ALL.into_iter().find(|c| c.name() == alias).ok_or_else(|| TfError::UnknownColormap {
            name: s.to_string(),
            known: Colormap::ALL.map(Colormap::name).join(", "),
        })
    }
}

impl TransferFunction {
    /// A copy whose colour nodes are `map` spread over [lo, hi] (opacity,
    /// widgets and everything else kept).
    pub fn with_colormap(&self, map: Colormap, lo: f64, hi: f64) -> Result<TransferFunction, TfError> {
        TransferFunction::new(
            map.nodes(lo, hi),
            self.opacity_nodes().to_vec(),
            self.unit_distance(),
            self.emission(),
            self.normalized(),
        )?
        .with_widgets(self.widgets().to_vec())
    }

    /// A copy with every extinction (1D opacity nodes and 2D widgets)
    /// multiplied by `factor` (finite, ≥ 0).
    pub fn with_opacity_scale(&self, factor: f64) -> Result<TransferFunction, TfError> {
        if !factor.is_finite() || factor < 0.0 {
            return Err(TfError::OpacityScale(factor));
        }
        let opacity = self.opacity_nodes().iter().map(|o| crate::tf::OpacityNode { x: o.x, a: o.a * factor }).collect();
        let widgets = self
            .widgets()
            .iter()
            .map(|w| {
                let mut w = *w;
                w.opacity *= factor;
                w
            })
            .collect();
        TransferFunction::new(
            self.color_nodes().to_vec(),
            opacity,
            self.unit_distance(),
            self.emission(),
            self.normalized(),
        )?
        .with_widgets(widgets)
    }
}

const VIRIDIS: [[f64; 3]; 17] = [
    [0.267004, 0.004874, 0.329415],
    [0.282327, 0.094955, 0.417331],
    [0.278826, 0.175490, 0.483397],
    [0.258965, 0.251537, 0.524736],
    [0.229739, 0.322361, 0.545706],
    [0.199430, 0.387607, 0.554642],
    [0.172719, 0.448791, 0.557885],
    [0.149039, 0.508051, 0.557250],
    [0.127568, 0.566949, 0.550556],
    [0.120081, 0.622161, 0.534946],
    [0.153894, 0.680203, 0.504172],
    [0.239374, 0.735588, 0.455688],
    [0.360741, 0.785964, 0.387814],
    [0.506271, 0.828786, 0.300362],
    [0.668054, 0.861999, 0.196293],
    [0.835270, 0.886029, 0.102646],
    [0.993248, 0.906157, 0.143936],
];
const INFERNO: [[f64; 3]; 17] = [
    [0.001462, 0.000466, 0.013866],
    [0.042253, 0.028139, 0.141141],
    [0.129285, 0.047293, 0.290788],
    [0.238273, 0.036621, 0.396353],
    [0.341500, 0.062325, 0.429425],
    [0.441207, 0.099338, 0.431594],
    [0.540920, 0.134729, 0.415123],
    [0.640135, 0.171438, 0.381065],
    [0.735683, 0.215906, 0.330245],
    [0.817341, 0.270954, 0.270390],
    [0.890341, 0.347957, 0.198286],
    [0.944285, 0.442772, 0.120354],
    [0.977092, 0.550850, 0.039050],
    [0.987945, 0.667748, 0.058329],
    [0.976108, 0.789974, 0.196018],
    [0.948683, 0.910473, 0.395289],
    [0.988362, 0.998364, 0.644924],
];
const MAGMA: [[f64; 3]; 17] = [
    [0.001462, 0.000466, 0.013866],
    [0.039608, 0.031090, 0.133515],
    [0.113094, 0.065492, 0.276784],
    [0.211718, 0.061992, 0.418647],
    [0.316654, 0.071690, 0.485380],
    [0.414709, 0.110431, 0.504662],
    [0.512831, 0.148179, 0.507648],
    [0.613617, 0.181811, 0.498536],
    [0.716387, 0.214982, 0.475290],
    [0.810855, 0.252861, 0.439305],
    [0.899552, 0.314616, 0.391037],
    [0.958464, 0.411324, 0.360014],
    [0.985693, 0.528148, 0.379371],
    [0.995810, 0.646344, 0.441361],
    [0.997019, 0.762398, 0.528821],
    [0.992831, 0.877168, 0.633109],
    [0.987053, 0.991438, 0.749504],
];
const PLASMA: [[f64; 3]; 17] = [
    [0.050383, 0.029803, 0.527975],
    [0.193374, 0.018354, 0.590330],
    [0.299855, 0.009561, 0.631624],
    [0.399411, 0.000859, 0.656133],
    [0.494877, 0.011990, 0.657865],
    [0.584391, 0.068579, 0.632812],
    [0.665129, 0.138566, 0.585582],
    [0.736019, 0.209439, 0.527908],
    [0.798216, 0.280197, 0.469538],
    [0.850066, 0.347048, 0.417153],
    [0.898984, 0.420392, 0.363047],
    [0.940313, 0.497642, 0.309197],
    [0.971835, 0.580382, 0.254931],
    [0.990681, 0.669558, 0.201642],
    [0.993482, 0.765499, 0.156891],
    [0.976265, 0.868016, 0.143351],
    [0.940015, 0.975158, 0.131326],
];
const TURBO: [[f64; 3]; 17] = [
    [0.189950, 0.071760, 0.232170],
    [0.251070, 0.252370, 0.633740],
    [0.276280, 0.421180, 0.891230],
    [0.258620, 0.579580, 0.998760],
    [0.158440, 0.735510, 0.923050],
    [0.092670, 0.865540, 0.762300],
    [0.196590, 0.949010, 0.594660],
    [0.427780, 0.994190, 0.385750],
    [0.643620, 0.989990, 0.233560],
    [0.795240, 0.930250, 0.203860],
    [0.926660, 0.820250, 0.225700],
    [0.991630, 0.684080, 0.207060],
    [0.985900, 0.504790, 0.133670],
    [0.926230, 0.324730, 0.058370],
    [0.823990, 0.191820, 0.019660],
    [0.675350, 0.089800, 0.004490],
    [0.479600, 0.015830, 0.010550],
];
const COOL_TO_WARM: [[f64; 3]; 17] = [
    [0.230033, 0.298999, 0.754002],
    [0.304189, 0.406783, 0.845198],
    [0.383382, 0.509628, 0.917551],
    [0.467041, 0.604729, 0.968249],
    [0.553295, 0.689052, 0.995412],
    [0.639456, 0.759682, 0.998143],
    [0.722389, 0.813999, 0.976535],
    [0.798791, 0.849807, 0.931630],
    [0.865390, 0.865419, 0.865326],
    [0.924216, 0.827434, 0.774535],
    [0.959016, 0.769862, 0.678103],
    [0.970175, 0.694406, 0.579504],
    [0.958270, 0.603021, 0.481899],
    [0.924245, 0.497519, 0.388048],
    [0.869509, 0.378546, 0.300265],
    [0.795962, 0.241539, 0.220415],
    [0.705998, 0.016126, 0.150001],
];

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_and_unknown_names_list_the_known() {
        for c in Colormap::ALL {
            assert_eq!(c.name().parse::<Colormap>().unwrap(), c);
            assert_eq!(c.sample(0.0), c.control_points()[0]);
            assert_eq!(c.sample(1.0), *c.control_points().last().unwrap());
        }
        assert_eq!("coolwarm".parse::<Colormap>().unwrap(), Colormap::CoolToWarm);
        let e = "jett".parse::<Colormap>().unwrap_err().to_string();
        assert!(e.contains("jett") && e.contains("viridis") && e.contains("turbo"), "{e}");
    }

    #[test]
    fn published_values() {
        // matplotlib's viridis entries 0, 128 and 255; Moreland's midpoint.
        assert_eq!(Colormap::Viridis.sample(0.0), [0.267004, 0.004874, 0.329415]);
        assert_eq!(Colormap::Viridis.sample(0.5), [0.127568, 0.566949, 0.550556]);
        assert_eq!(Colormap::Viridis.sample(1.0), [0.993248, 0.906157, 0.143936]);
        let mid = Colormap::CoolToWarm.sample(0.5);
        assert!(mid.iter().all(|v| (v - 0.865).abs() < 1e-3), "{mid:?}");
        assert_eq!(Colormap::Grayscale.sample(0.25), [0.25; 3]);
    }

    #[test]
    fn recolouring_and_scaling_keep_the_rest() {
        let tf = TransferFunction::from_json(
            r#"{"color": [[0, 1, 0, 0], [1, 0, 0, 1]], "opacity": [[0, 0.5], [1, 3]], "unit_distance": 2}"#,
        )
        .unwrap();
        let t = tf.with_colormap(Colormap::Inferno, 0.0, 1.0).unwrap();
        assert_eq!(t.opacity_nodes(), tf.opacity_nodes());
        assert_eq!(t.color_nodes().len(), 17);
        assert_eq!(t.color(1.0), Colormap::Inferno.sample(1.0));
        let s = tf.with_opacity_scale(2.0).unwrap();
        assert_eq!(s.opacity_nodes()[1].a, 6.0);
        assert_eq!(s.unit_distance(), 2.0);
        assert!(tf.with_opacity_scale(f64::NAN).is_err() && tf.with_opacity_scale(-1.0).is_err());
    }
}
