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
    /// `clamp_min <= threshold <= clamp_max`.
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

    /// `true` when the value sits at either clamp (OctoMap's `isNodeAtThreshold`).
    #[inline]
    pub fn is_at_threshold(&self, l: f32) -> bool {
        l >= self.clamp_max || l <= self.clamp_min
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
    fn rejects_bad_probabilities() {
        assert!(OccupancyParams::from_probabilities(0.3, 0.4, 0.1, 0.9, 0.5).is_err());
        assert!(OccupancyParams::from_probabilities(0.7, 0.6, 0.1, 0.9, 0.5).is_err());
        assert!(OccupancyParams::from_probabilities(0.7, 0.4, 0.9, 0.1, 0.5).is_err());
        assert!(OccupancyParams::from_probabilities(f64::NAN, 0.4, 0.1, 0.9, 0.5).is_err());
        assert!(OccupancyParams::from_probabilities(0.7, 0.4, 0.1192, 0.971, 0.5).is_ok());
    }
}
