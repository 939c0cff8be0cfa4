//! RANSAC line extraction from one 2D scan, the second baseline of Nguyen et al. (2007) against
//! which the angular segmentation is compared.
//!
//! Repeatedly: among the points not yet on a line, the line through two random points with the
//! most points within [`RansacParams::inlier_distance`] (over
//! [`RansacParams::iterations`] draws) is refitted by total least squares (TLS) to those
//! inliers, and the inliers are taken again from the refitted line. RANSAC finds infinite
//! lines, so the inliers are then cut where consecutive ones (by position along the line) are
//! farther apart than [`RansacParams::max_gap`], as the angular segmentation's collinear lines
//! separation does; every piece with enough points is a [`Line`](crate::Line). All the inliers
//! leave the pool, and the search stops when the best line has fewer than
//! [`RansacParams::min_line_points`] inliers. The draws come from a seeded generator, so the
//! result is deterministic.

use crate::error::{check_non_negative, SegmentError};
use crate::laser_lines::{fit_line, Segmentation};

/// Knobs of [`ransac_lines`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RansacParams {
    /// Largest distance of an inlier from the line, metres (default 0.05, the angular
    /// segmentation's `eps_dist`).
    pub inlier_distance: f64,
    /// Random two-point draws per line (default 200).
    pub iterations: usize,
    /// Inliers farther apart than this along the line make separate lines, metres (default
    /// 0.5, the angular segmentation's `split_eps`).
    pub max_gap: f64,
    /// Lines need at least this many inliers (default 5, never below 2).
    pub min_line_points: usize,
    /// Seed of the draws.
    pub seed: u64,
}

impl Default for RansacParams {
    fn default() -> Self {
        Self {
            inlier_distance: 0.05,
            iterations: 200,
            max_gap: 0.5,
            min_line_points: 5,
            seed: 0x5EED,
        }
    }
}

/// splitmix64: a small deterministic generator for the draws.
struct Draws(u64);

impl Draws {
    fn below(&mut self, n: usize) -> usize {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        ((u128::from(z) * n as u128) >> 64) as usize
    }
}

/// Unit normal `(nx, ny)` and offset `d` of the line through `a` and `b`; `None` when they
/// coincide.
fn line_through(a: [f64; 2], b: [f64; 2]) -> Option<(f64, f64, f64)> {
    let (ex, ey) = (b[0] - a[0], b[1] - a[1]);
    let len = ex.hypot(ey);
    if !(len > 0.0 && len.is_finite()) {
        return None;
    }
    let (nx, ny) = (-ey / len, ex / len);
    Some((nx, ny, nx * a[0] + ny * a[1]))
}

/// RANSAC lines of one scan into `out` (read with [`Segmentation::lines`],
/// [`Segmentation::labels`] and [`Segmentation::line_members`]).
///
/// Errors on a non-finite coordinate or bad `params`.
pub fn ransac_lines(
    points: &[[f64; 2]],
    params: &RansacParams,
    out: &mut Segmentation,
) -> Result<(), SegmentError> {
    check_non_negative(&[
        ("inlier_distance", params.inlier_distance),
        ("max_gap", params.max_gap),
    ])?;
    let found = out.start(points)?;
    let min_line = params.min_line_points.max(2);
    let tol = params.inlier_distance;
    let mut pool: Vec<u32> = (0..points.len() as u32).collect();
    let mut draws = Draws(params.seed);
    let mut inliers: Vec<u32> = Vec::new();
    let mut along: Vec<(f64, u32)> = Vec::new();
    let mut piece: Vec<u32> = Vec::new();
    let count = |pool: &[u32], (nx, ny, d): (f64, f64, f64)| {
        pool.iter()
            .filter(|&&i| {
                let p = points[i as usize];
                (p[0] * nx + p[1] * ny - d).abs() <= tol
            })
            .count()
    };
    while pool.len() >= min_line {
        let mut best: Option<((f64, f64, f64), usize)> = None;
        for _ in 0..params.iterations {
            let i = draws.below(pool.len());
            let j = draws.below(pool.len() - 1);
            let j = if j >= i { j + 1 } else { j };
            let (a, b) = (points[pool[i] as usize], points[pool[j] as usize]);
            let Some(line) = line_through(a, b) else {
                continue;
            };
            let c = count(&pool, line);
            if best.is_none_or(|(_, bc)| c > bc) {
                best = Some((line, c));
            }
        }
        let Some((line, c)) = best else { break };
        if c < min_line {
            break;
        }
        // Refit by TLS to the inliers, then take the inliers of the refitted line.
        let (nx, ny, d) = line;
        inliers.clear();
        inliers.extend(pool.iter().copied().filter(|&i| {
            let p = points[i as usize];
            (p[0] * nx + p[1] * ny - d).abs() <= tol
        }));
        if let Some(fit) = fit_line(points, &inliers) {
            let (s, c) = fit.normal_angle.sin_cos();
            let refit: Vec<u32> = pool
                .iter()
                .copied()
                .filter(|&i| {
                    let p = points[i as usize];
                    (p[0] * c + p[1] * s - fit.distance).abs() <= tol
                })
                .collect();
            // Keep the refit's inliers unless they are fewer (the draw's set is a fallback).
            if refit.len() >= inliers.len() {
                inliers = refit;
            }
        }
        let Some(fit) = fit_line(points, &inliers) else {
            // All inliers coincide: drop them and go on.
            pool.retain(|i| !inliers.contains(i));
            continue;
        };
        let (s, c) = fit.normal_angle.sin_cos();
        along.clear();
        along.extend(inliers.iter().map(|&i| {
            let p = points[i as usize];
            (-p[0] * s + p[1] * c, i)
        }));
        along.sort_unstable_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
        let mut k = 0;
        while k < along.len() {
            let mut e = k + 1;
            while e < along.len() && along[e].0 - along[e - 1].0 <= params.max_gap {
                e += 1;
            }
            if e - k >= min_line {
                piece.clear();
                piece.extend(along[k..e].iter().map(|v| v.1));
                piece.sort_unstable();
                found.emit(points, &piece);
            }
            k = e;
        }
        inliers.sort_unstable();
        pool.retain(|i| inliers.binary_search(i).is_err());
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn corner_and_collinear_pieces() {
        let mut pts: Vec<[f64; 2]> = (0..30).map(|i| [3.0, -1.0 + 0.1 * i as f64]).collect();
        pts.extend((0..30).map(|i| [2.9 - 0.1 * i as f64, 2.0]));
        pts.extend((0..10).map(|i| [-1.0 - 0.1 * i as f64, 2.0]));
        let mut out = Segmentation::new();
        ransac_lines(&pts, &RansacParams::default(), &mut out).unwrap();
        let mut d: Vec<(f64, usize)> = out
            .lines()
            .iter()
            .map(|l| ((l.distance * 1e6).round() / 1e6, l.n_points))
            .collect();
        d.sort_by(|a, b| a.partial_cmp(b).unwrap());
        assert_eq!(d, vec![(2.0, 10), (2.0, 30), (3.0, 30)]);
        let mut again = Segmentation::new();
        ransac_lines(&pts, &RansacParams::default(), &mut again).unwrap();
        assert_eq!(out.lines(), again.lines(), "deterministic");
        assert!(ransac_lines(&[[0.0, f64::INFINITY]], &RansacParams::default(), &mut out).is_err());
    }
}
