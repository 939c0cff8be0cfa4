//! The options of a mapping run: [`MapperOptions`] and its [`InsertMode`], and their text
//! form ([`MapperOptions::settings`]), which a checkpoint records and compares.
//!
//! They live apart from the [`Mapper`](crate::pipeline::Mapper) that uses them because the
//! checkpoint manifest ([`crate::checkpoint`]) records them too: with the options here, the
//! pipeline depends on the checkpoint and both on the options, and never the other way round.
//! Users name them by their public paths, `octoquant::pipeline::MapperOptions` and
//! `octoquant::pipeline::InsertMode`, which re-export them.

use crate::filters::{CropBox, GroundFilter, PointFilters};
use octoquant_octree::OccupancyParams;
use octoquant_quantize::QuantizeOptions;

/// How a frame's end points become rays.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum InsertMode {
    /// OctoMap's `insertPointCloud`: one ray per end point.
    #[default]
    Exact,
    /// OctoMap's `discretize = true`, computed as OctoMap does (unique end-point keys, rays to
    /// voxel centres).
    Discretize,
    /// The dense voxel-key quantization pre-pass (Kwon & Yoon): same tree as `Discretize`,
    /// computed with a bit grid over the frame's key box.
    Quantized,
    /// The quantization pre-pass, then integer Bresenham rays between voxel keys: the fastest
    /// mode; same occupied voxels as `Quantized`, slightly less free space (see
    /// `octoquant_raycast::walk_bresenham_keys`). Not OctoMap-identical.
    QuantizedBresenham,
    /// OctoMap's `insertPointCloudRays` (graph2tree `-simple`): per point, misses along the
    /// ray then a hit, no deduplication, no maximum range.
    Simple,
}

impl InsertMode {
    /// The mode's one name: the `--mode` value on the command line, and the name in text and
    /// JSON output (`exact`, `discretize`, `quantized`, `quantized+bresenham`, `simple`).
    pub fn name(self) -> &'static str {
        match self {
            InsertMode::Exact => "exact",
            InsertMode::Discretize => "discretize",
            InsertMode::Quantized => "quantized",
            InsertMode::QuantizedBresenham => "quantized+bresenham",
            InsertMode::Simple => "simple",
        }
    }
}

/// Everything that configures a [`Mapper`](crate::pipeline::Mapper); `Default` is OctoMap's
/// default insertion at 0.1 m.
#[derive(Debug, Clone, PartialEq)]
pub struct MapperOptions {
    /// Leaf size in metres.
    pub resolution: f64,
    /// Sensor model (hit/miss, clamping, threshold).
    pub params: OccupancyParams,
    /// Readings beyond this distance only clear space (OctoMap's `maxrange`); `None` = off.
    pub max_range: Option<f64>,
    /// How end points become rays.
    pub mode: InsertMode,
    /// Skip inner-node upkeep during insertion; [`Mapper::finish`](crate::pipeline::Mapper::finish)
    /// restores it.
    pub lazy: bool,
    /// Thin each frame with the online density reducer first (cell size per axis, metres).
    pub reduce: Option<[f64; 3]>,
    /// Limits of the dense quantization grid.
    pub quantize: QuantizeOptions,
    /// Points to drop before insertion (octomap_server's filters and more; see
    /// [`crate::filters`]). The default drops nothing.
    pub filters: PointFilters,
}

impl Default for MapperOptions {
    fn default() -> Self {
        MapperOptions {
            resolution: 0.1,
            params: OccupancyParams::default(),
            max_range: None,
            mode: InsertMode::Exact,
            lazy: false,
            reduce: None,
            quantize: QuantizeOptions::default(),
            filters: PointFilters::default(),
        }
    }
}

impl MapperOptions {
    /// The options as `(name, value)` pairs in a fixed order, every number in its shortest
    /// exact form: what a checkpoint records, so that a resumed run is refused when any of
    /// them differs (see [`crate::checkpoint`]).
    pub fn settings(&self) -> Vec<(&'static str, String)> {
        options_to_settings(self)
    }
}

/// The options as `(name, value)` lines, every float in its shortest exact form, in a fixed
/// order: what a checkpoint stores and compares.
pub(crate) fn options_to_settings(o: &MapperOptions) -> Vec<(&'static str, String)> {
    let p = &o.params;
    let f = &o.filters;
    vec![
        ("resolution", format!("{:?}", o.resolution)),
        ("mode", o.mode.name().to_string()),
        ("prob_hit_log", format!("{:?}", p.hit)),
        ("prob_miss_log", format!("{:?}", p.miss)),
        ("clamp_min_log", format!("{:?}", p.clamp_min)),
        ("clamp_max_log", format!("{:?}", p.clamp_max)),
        (
            "occupancy_threshold_log",
            format!("{:?}", p.occupancy_threshold),
        ),
        (
            "max_range",
            o.max_range.map_or("none".into(), |m| format!("{m:?}")),
        ),
        ("lazy", o.lazy.to_string()),
        (
            "reduce",
            o.reduce
                .map_or("none".into(), |[x, y, z]| format!("{x:?} {y:?} {z:?}")),
        ),
        (
            "quantize_max_grid_bits",
            o.quantize.max_grid_bits.to_string(),
        ),
        (
            "quantize_bits_per_point",
            o.quantize.bits_per_point.to_string(),
        ),
        (
            "quantize_parallel_threshold",
            o.quantize.parallel_threshold.to_string(),
        ),
        ("drop_zero", f.drop_zero.to_string()),
        ("min_range", opt(f.min_range)),
        ("crop_sensor", crop(&f.crop_sensor)),
        ("crop_world", crop(&f.crop_world)),
        ("z_min", opt(f.z_min)),
        ("z_max", opt(f.z_max)),
        (
            "ground",
            f.ground.map_or("none".into(), |g| {
                // " clear" only when set, so that a dropping filter reads as before
                let clear = if g.clear { " clear" } else { "" };
                format!(
                    "{:?} {:?} {} {}{clear}",
                    g.distance, g.angle, g.iterations, g.seed
                )
            }),
        ),
    ]
}

/// An optional number as a setting value: `none`, or the number in its shortest exact form.
fn opt(v: Option<f64>) -> String {
    v.map_or("none".into(), |v| format!("{v:?}"))
}

/// An optional crop box as a setting value: `none`, or its six bounds, space-separated.
fn crop(b: &Option<CropBox>) -> String {
    b.map_or("none".into(), |b| {
        b.to_array()
            .iter()
            .map(|v| format!("{v:?}"))
            .collect::<Vec<_>>()
            .join(" ")
    })
}

/// `v` as space-separated numbers, `n` of them.
fn numbers(v: &str, n: usize) -> Result<Vec<f64>, String> {
    let c: Vec<f64> = v.split(' ').map(parse_num).collect::<Result<_, _>>()?;
    if c.len() != n {
        return Err(format!("{v:?} is not {n} numbers"));
    }
    Ok(c)
}

/// A number of a setting or manifest value, or the message that names the text that is not
/// one (shared with the checkpoint manifest's own fields, so that both say it alike).
pub(crate) fn parse_num<T: std::str::FromStr>(v: &str) -> Result<T, String> {
    v.parse().map_err(|_| format!("{v:?} is not a number"))
}

/// The inverse of [`options_to_settings`]: set the option named `key` of `o` from its text
/// `v`; `Ok(false)` for a name that is no option, `Err` for a value that does not parse.
pub(crate) fn set_option(o: &mut MapperOptions, key: &str, v: &str) -> Result<bool, String> {
    let opt_f64 = |v: &str| -> Result<Option<f64>, String> {
        if v == "none" {
            Ok(None)
        } else {
            parse_num(v).map(Some)
        }
    };
    match key {
        "resolution" => o.resolution = parse_num(v)?,
        "mode" => {
            o.mode = [
                InsertMode::Exact,
                InsertMode::Discretize,
                InsertMode::Quantized,
                InsertMode::QuantizedBresenham,
                InsertMode::Simple,
            ]
            .into_iter()
            .find(|m| m.name() == v)
            .ok_or_else(|| format!("unknown mode {v:?}"))?
        }
        "prob_hit_log" => o.params.hit = parse_num(v)?,
        "prob_miss_log" => o.params.miss = parse_num(v)?,
        "clamp_min_log" => o.params.clamp_min = parse_num(v)?,
        "clamp_max_log" => o.params.clamp_max = parse_num(v)?,
        "occupancy_threshold_log" => o.params.occupancy_threshold = parse_num(v)?,
        "max_range" => o.max_range = opt_f64(v)?,
        "lazy" => o.lazy = v.parse().map_err(|_| format!("{v:?} is not true/false"))?,
        "reduce" => {
            o.reduce = if v == "none" {
                None
            } else {
                let c: Vec<f64> = v.split(' ').map(parse_num).collect::<Result<_, _>>()?;
                match c[..] {
                    [x, y, z] => Some([x, y, z]),
                    _ => return Err(format!("{v:?} is not three cell sizes")),
                }
            }
        }
        "quantize_max_grid_bits" => o.quantize.max_grid_bits = parse_num(v)?,
        "quantize_bits_per_point" => o.quantize.bits_per_point = parse_num(v)?,
        "quantize_parallel_threshold" => o.quantize.parallel_threshold = parse_num(v)?,
        "drop_zero" => {
            o.filters.drop_zero = v.parse().map_err(|_| format!("{v:?} is not true/false"))?
        }
        "min_range" => o.filters.min_range = opt_f64(v)?,
        "crop_sensor" | "crop_world" => {
            let b = if v == "none" {
                None
            } else {
                Some(CropBox::from_slice(key, &numbers(v, 6)?).map_err(|e| e.to_string())?)
            };
            if key == "crop_sensor" {
                o.filters.crop_sensor = b;
            } else {
                o.filters.crop_world = b;
            }
        }
        "z_min" => o.filters.z_min = opt_f64(v)?,
        "z_max" => o.filters.z_max = opt_f64(v)?,
        "ground" => {
            o.filters.ground = if v == "none" {
                None
            } else {
                let mut it = v.split(' ');
                let (Some(d), Some(a), Some(i), Some(s), clear, None) = (
                    it.next(),
                    it.next(),
                    it.next(),
                    it.next(),
                    it.next(),
                    it.next(),
                ) else {
                    return Err(format!(
                        "{v:?} is not: distance angle iterations seed [clear]"
                    ));
                };
                let clear = match clear {
                    None => false,
                    Some("clear") => true,
                    Some(w) => return Err(format!("{w:?} is not \"clear\" in ground {v:?}")),
                };
                Some(GroundFilter {
                    distance: parse_num(d)?,
                    angle: parse_num(a)?,
                    iterations: parse_num(i)?,
                    seed: parse_num(s)?,
                    clear,
                })
            }
        }
        _ => return Ok(false),
    }
    Ok(true)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn options_round_trip_exactly() {
        let mut o = MapperOptions {
            resolution: 0.123456789,
            max_range: Some(7.25),
            mode: InsertMode::QuantizedBresenham,
            lazy: true,
            reduce: Some([0.1, 0.2, 1.0 / 3.0]),
            filters: PointFilters {
                drop_zero: true,
                min_range: Some(0.3),
                crop_sensor: Some(
                    CropBox::from_slice("b", &[-0.5, -0.25, -1.0, 0.5, 0.25, 0.1]).unwrap(),
                ),
                crop_world: Some(
                    CropBox::from_slice("b", &[-1e3, -2e3, -3.0, 1e3, 2e3, 1.0 / 3.0]).unwrap(),
                ),
                z_min: Some(-0.7),
                z_max: Some(2.5),
                ground: Some(GroundFilter {
                    distance: 0.05,
                    angle: 0.2,
                    iterations: 77,
                    seed: u64::MAX,
                    clear: true,
                }),
            },
            ..MapperOptions::default()
        };
        o.params.hit = 0.8472979;
        o.quantize.bits_per_point = 17;
        let mut back = MapperOptions::default();
        for (k, v) in options_to_settings(&o) {
            assert!(set_option(&mut back, k, &v).unwrap(), "{k}");
        }
        assert_eq!(back, o);
    }
}
