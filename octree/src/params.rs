//! The sensor model: hit/miss updates, clamping and the occupancy threshold, in f32 log-odds.

use crate::error::OctreeError;

/// Log-odds of probability `p`, computed in double and stored as `f32`, exactly as OctoMap's
/// `logodds(double)` (so 0.7 gives `0x3f58e883`, not a rounded constant).
#[inline]
pub fn logodds(p: f64) -> f32 {
    (p / (1.0 - p)).ln() as f32
}

/// Probability of a log-odds value: `1 - 1/(1 + exp(l))`, as OctoMap's `probability()`.
#[inline]
pub fn probability(l: f64) -> f64 {
    1.0 - 1.0 / (1.0 + l.exp())
}

/// The occupancy sensor model, stored as the `f32` log-odds OctoMap uses internally.
///
/// `Default` gives OctoMap's defaults: hit 0.7, miss 0.4, clamping 0.1192 / 0.971,
/// threshold 0.5.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OccupancyParams {
    /// Log-odds added on a hit (`prob_hit_log`, >= 0).
    pub hit: f32,
    /// Log-odds added on a miss (`prob_miss_log`, <= 0).
    pub miss: f32,
    /// Lower clamping bound (`clamping_thres_min`).
    pub clamp_min: f32,
    /// Upper clamping bound (`clamping_thres_max`).
    pub clamp_max: f32,
    /// A node is occupied when its log-odds is `>=` this (`occ_prob_thres_log`).
    pub occupancy_threshold: f32,
}

impl Default for OccupancyParams {
    fn default() -> Self {
        OccupancyParams {
            hit: logodds(0.7),
            miss: logodds(0.4),
            clamp_min: logodds(0.1192),
            clamp_max: logodds(0.971),
            occupancy_threshold: logodds(0.5),
        }
    }
}

fn check_prob(name: &'static str, value: f64) -> Result<(), OctreeError> {
    if value.is_finite() && value > 0.0 && value < 1.0 {
        Ok(())
    } else {
        Err(OctreeError::InvalidProbability {
            name,
            value,
            reason: "must lie strictly between 0 and 1",
        })
    }
}

impl OccupancyParams {
    /// A sensor model from probabilities, converted like OctoMap's setters.
    ///
    /// Errors unless every probability is in (0, 1), `hit >= 0.5`, `miss <= 0.5` and
    /// `clamp_min <= clamp_max`. As in OctoMap, the threshold may lie outside the clamping
    /// range (then every voxel holds one class); callers that want both classes reachable
    /// check that themselves.
    pub fn from_probabilities(
        hit: f64,
        miss: f64,
        clamp_min: f64,
        clamp_max: f64,
        threshold: f64,
    ) -> Result<Self, OctreeError> {
        for (n, v) in [
            ("hit", hit),
            ("miss", miss),
            ("clamping min", clamp_min),
            ("clamping max", clamp_max),
            ("occupancy threshold", threshold),
        ] {
            check_prob(n, v)?;
        }
        let p = OccupancyParams {
            hit: logodds(hit),
            miss: logodds(miss),
            clamp_min: logodds(clamp_min),
            clamp_max: logodds(clamp_max),
            occupancy_threshold: logodds(threshold),
        };
        if p.hit < 0.0 {
            return Err(OctreeError::InvalidProbability {
                name: "hit",
                value: hit,
                reason: "a hit must not lower occupancy (needs >= 0.5)",
            });
        }
        if p.miss > 0.0 {
            return Err(OctreeError::InvalidProbability {
                name: "miss",
                value: miss,
                reason: "a miss must not raise occupancy (needs <= 0.5)",
            });
        }
        if p.clamp_min > p.clamp_max {
            return Err(OctreeError::InvalidProbability {
                name: "clamping min",
                value: clamp_min,
                reason: "must not exceed clamping max",
            });
        }
        Ok(p)
    }

    /// Clamp a log-odds value into `[clamp_min, clamp_max]`.
    #[inline]
    pub fn clamp(&self, l: f32) -> f32 {
        l.max(self.clamp_min).min(self.clamp_max)
    }

    /// `true` when a node with this log-odds counts as occupied (`>=` threshold).
    #[inline]
    pub fn is_occupied(&self, l: f32) -> bool {
        l >= self.occupancy_threshold
    }

    /// The clamp on the side of the threshold `l` lies (OctoMap's `nodeToMaxLikelihood`):
    /// the upper clamp for an occupied value, the lower one otherwise.
    #[inline]
    pub fn max_likelihood(&self, l: f32) -> f32 {
        if self.is_occupied(l) {
            self.clamp_max
        } else {
            self.clamp_min
        }
    }

    /// `true` when the value sits at either clamp (OctoMap's `isNodeAtThreshold`).
    #[inline]
    pub fn is_at_threshold(&self, l: f32) -> bool {
        l >= self.clamp_max || l <= self.clamp_min
    }
}

/// A sensor model as the probabilities OctoMap's setters take (`setProbHit`, `setProbMiss`,
/// `setClampingThresMin/Max`, `setOccupancyThres`): the form a user states a model in, and the
/// form the C++ reference is given, so that both sides convert them to log-odds the same way.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SensorProbabilities {
    /// Probability of a hit (`>= 0.5`).
    pub hit: f64,
    /// Probability of a miss (`<= 0.5`).
    pub miss: f64,
    /// Lower clamping probability.
    pub clamp_min: f64,
    /// Upper clamping probability.
    pub clamp_max: f64,
    /// Occupancy threshold probability.
    pub threshold: f64,
}

impl SensorProbabilities {
    /// The log-odds model, checked as [`OccupancyParams::from_probabilities`] checks it.
    pub fn params(&self) -> Result<OccupancyParams, OctreeError> {
        OccupancyParams::from_probabilities(
            self.hit,
            self.miss,
            self.clamp_min,
            self.clamp_max,
            self.threshold,
        )
    }
}

/// Named sensor models, so that a paper's parameters are one word on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SensorPreset {
    /// OctoMap's defaults: hit 0.7, miss 0.4, clamping 0.1192 / 0.971, threshold 0.5.
    OctoMap,
    /// The values printed by Kwon and Yoon (KAIST, 2015) for their quantized OctoMap update:
    /// `l_occ = 0.2, l_free = -0.1, l_max = 0.9, l_min = 0.1`, units not stated. Read here
    /// as **log-odds for the two updates and probabilities for the two clamps**: hit
    /// `probability(0.2)` = 0.5498, miss `probability(-0.1)` = 0.4750, clamping 0.1 / 0.9.
    /// Why: `l_free` is negative, so the updates cannot be probabilities; read as log-odds,
    /// `l_min = 0.1` would be above the occupancy threshold (0), so no voxel could ever be
    /// free, which contradicts the paper's free-space maps, while as probabilities 0.1 / 0.9
    /// are ordinary clamps (log-odds -2.197 / 2.197, near OctoMap's -2.0 / 3.5). The
    /// threshold is OctoMap's 0.5 (the paper prints none).
    KwonYoon2015,
}

impl SensorPreset {
    /// Every preset, in the order the command line lists them.
    pub const ALL: [SensorPreset; 2] = [SensorPreset::OctoMap, SensorPreset::KwonYoon2015];

    /// The preset's name on the command line and in summaries.
    pub fn name(self) -> &'static str {
        match self {
            SensorPreset::OctoMap => "octomap",
            SensorPreset::KwonYoon2015 => "kwon-yoon-2015",
        }
    }

    /// The preset as OctoMap setter probabilities.
    pub fn probabilities(self) -> SensorProbabilities {
        match self {
            SensorPreset::OctoMap => SensorProbabilities {
                hit: 0.7,
                miss: 0.4,
                clamp_min: 0.1192,
                clamp_max: 0.971,
                threshold: 0.5,
            },
            SensorPreset::KwonYoon2015 => SensorProbabilities {
                hit: probability(0.2),
                miss: probability(-0.1),
                clamp_min: 0.1,
                clamp_max: 0.9,
                threshold: 0.5,
            },
        }
    }

    /// The preset's log-odds model.
    pub fn params(self) -> OccupancyParams {
        // both presets satisfy every check of `from_probabilities` (tested)
        self.probabilities()
            .params()
            .unwrap_or_else(|_| OccupancyParams::default())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_have_octomaps_bits() {
        let p = OccupancyParams::default();
        assert_eq!(p.hit.to_bits(), 0x3f58e883);
        assert_eq!(p.miss.to_bits(), 0xbecf991f);
        assert_eq!(p.clamp_min.to_bits(), 0xc0000075);
        assert_eq!(p.clamp_max.to_bits(), 0x4060b4ba);
        assert_eq!(p.occupancy_threshold.to_bits(), 0);
    }

    #[test]
    fn octomap_preset_is_the_default_model() {
        assert_eq!(SensorPreset::OctoMap.params(), OccupancyParams::default());
        assert!(SensorPreset::OctoMap.probabilities().params().is_ok());
    }

    /// The KAIST preset gives the paper's printed numbers back: log-odds 0.2 and -0.1 for
    /// the updates (to f32 rounding after the round trip through a probability), and clamps
    /// whose probabilities are 0.1 and 0.9, i.e. log-odds -ln 9 and ln 9.
    #[test]
    fn kwon_yoon_preset_gives_the_papers_numbers() {
        let pr = SensorPreset::KwonYoon2015.probabilities();
        let p = pr.params().expect("the preset is a valid model");
        assert_eq!(SensorPreset::KwonYoon2015.params(), p);
        assert!((p.hit - 0.2).abs() < 1e-6, "{}", p.hit);
        assert!((p.miss + 0.1).abs() < 1e-6, "{}", p.miss);
        let ln9 = 9f64.ln() as f32;
        assert!((p.clamp_max - ln9).abs() < 1e-6, "{}", p.clamp_max);
        assert!((p.clamp_min + ln9).abs() < 1e-6, "{}", p.clamp_min);
        // free space is reachable: the lower clamp lies below the occupancy threshold
        assert!(p.clamp_min < p.occupancy_threshold && p.occupancy_threshold < p.clamp_max);
        // and the preset's setter probabilities are the logistic of the printed log-odds
        assert!((pr.hit - 1.0 / (1.0 + (-0.2f64).exp())).abs() < 1e-15);
        assert!((pr.miss - 1.0 / (1.0 + (0.1f64).exp())).abs() < 1e-15);
    }

    #[test]
    fn preset_names_are_distinct() {
        let names: Vec<_> = SensorPreset::ALL.iter().map(|p| p.name()).collect();
        assert_eq!(names, ["octomap", "kwon-yoon-2015"]);
    }

    #[test]
    fn rejects_bad_probabilities() {
        assert!(OccupancyParams::from_probabilities(0.3, 0.4, 0.1, 0.9, 0.5).is_err());
        assert!(OccupancyParams::from_probabilities(0.7, 0.6, 0.1, 0.9, 0.5).is_err());
        assert!(OccupancyParams::from_probabilities(0.7, 0.4, 0.9, 0.1, 0.5).is_err());
        assert!(OccupancyParams::from_probabilities(f64::NAN, 0.4, 0.1, 0.9, 0.5).is_err());
        assert!(OccupancyParams::from_probabilities(0.7, 0.4, 0.1192, 0.971, 0.5).is_ok());
    }
}
