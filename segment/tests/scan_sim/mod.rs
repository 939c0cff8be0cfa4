//! A small 2D laser simulator for the tests: beams cast from the origin hit wall segments,
//! ranges get Gaussian noise from a seeded generator. It also keeps the ground truth: which
//! wall each point came from, and the noiseless hit.

#![allow(dead_code)]

/// A deterministic generator (splitmix64) with uniform and Gaussian draws.
pub struct Rng(pub u64);

impl Rng {
    /// Uniform in `[0, 1)`.
    pub fn uniform(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Standard normal (Box-Muller).
    pub fn gaussian(&mut self) -> f64 {
        let u1 = 1.0 - self.uniform();
        let u2 = self.uniform();
        (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
    }
}

/// A wall: the segment between two points, in the sensor frame.
pub type Wall = [[f64; 2]; 2];

/// One simulated scan, in beam order.
pub struct Scan {
    /// The measured points (noisy ranges along the beams).
    pub points: Vec<[f64; 2]>,
    /// The noiseless hit of each point.
    pub clean: Vec<[f64; 2]>,
    /// Index into the walls of the wall each point hit.
    pub wall: Vec<usize>,
    /// The beam direction of each point, radians.
    pub beam: Vec<f64>,
}

fn cross(a: [f64; 2], b: [f64; 2]) -> f64 {
    a[0] * b[1] - a[1] * b[0]
}

/// Cast one beam per angle (radians, in order) from the origin against `walls`; the nearest
/// hit within `max_range` gives a point with range noise of standard deviation `sigma`.
/// Beams that hit nothing give no point.
pub fn scan(walls: &[Wall], angles: &[f64], max_range: f64, sigma: f64, seed: u64) -> Scan {
    let mut rng = Rng(seed);
    let mut out = Scan {
        points: Vec::new(),
        clean: Vec::new(),
        wall: Vec::new(),
        beam: Vec::new(),
    };
    for &a in angles {
        let d = [a.cos(), a.sin()];
        let mut best: Option<(f64, usize)> = None;
        for (k, w) in walls.iter().enumerate() {
            let e = [w[1][0] - w[0][0], w[1][1] - w[0][1]];
            let denom = cross(d, e);
            if denom.abs() < 1e-12 {
                continue;
            }
            let r = cross(w[0], e) / denom;
            let s = cross(w[0], d) / denom;
            if r > 0.0 && (0.0..=1.0).contains(&s) && best.is_none_or(|(b, _)| r < b) {
                best = Some((r, k));
            }
        }
        let Some((r, k)) = best else { continue };
        if r > max_range {
            continue;
        }
        let noisy = r + sigma * rng.gaussian();
        out.points.push([noisy * d[0], noisy * d[1]]);
        out.clean.push([r * d[0], r * d[1]]);
        out.wall.push(k);
        out.beam.push(a);
    }
    out
}

/// `n` beam angles from `from` to `to` degrees inclusive, in radians.
pub fn beams(from: f64, to: f64, n: usize) -> Vec<f64> {
    (0..n)
        .map(|i| (from + (to - from) * i as f64 / (n - 1) as f64).to_radians())
        .collect()
}

/// The spacing between neighbouring beams' hits near `p` on a wall of unit direction `u`,
/// for beams `step` radians apart: range times step over the cosine of the incidence.
pub fn spacing(p: [f64; 2], u: [f64; 2], step: f64) -> f64 {
    let r = p[0].hypot(p[1]);
    let along_beam = (p[0] * u[0] + p[1] * u[1]).abs() / r;
    let cos_incidence = (1.0 - along_beam * along_beam).max(1e-6).sqrt();
    r * step / cos_incidence
}
