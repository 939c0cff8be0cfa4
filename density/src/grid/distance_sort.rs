//! A bucket sort of `(distance, slot)` pairs: the distance order of a build.

/// Sort `(distance bits, slot)` pairs ascending (by bits, then slot), where every bits value is
/// that of a non-negative `f64` (so the bits order is the value order), with buckets spread
/// over the data's own range. See [`DistanceSort`].
#[cfg(test)]
pub(crate) fn sort_by_distance(v: &mut Vec<(u64, u32)>) {
    let max = v
        .iter()
        .map(|e| f64::from_bits(e.0))
        .fold(0.0f64, |m, d| if d > m { d } else { m });
    let mut sort = DistanceSort::new(v.len(), max);
    for e in v.iter() {
        sort.count(e.0);
    }
    *v = sort.place(v.iter().copied());
}

/// A bucket sort of `(distance bits, slot)` pairs on the distance value (bits of non-negative
/// `f64`s), fed in two passes so that the caller need not hold the pairs in between: first
/// [`DistanceSort::count`] every distance, then [`DistanceSort::place`] the pairs.
///
/// Each pair goes to bucket `floor(value * scale)` (monotone in the value; values beyond the
/// expected maximum go to the last bucket), the buckets are filled in one pass, and each bucket
/// is then sorted on the full pair (insertion sort when small, else a comparison sort). About
/// three passes over the pairs for any spread of distances; no quadratic case. The pairs are
/// distinct when the slots are, so the result is the unique sorted order.
pub(crate) struct DistanceSort {
    scale: f64,
    /// Per bucket: the count, then (after `place`) the end of its run.
    ends: Vec<u32>,
}

impl DistanceSort {
    /// A sort of `n` pairs whose distances mostly lie in `0..=max`.
    pub(crate) fn new(n: usize, max: f64) -> Self {
        let buckets = n.clamp(1, 1 << 20);
        let top = (buckets - 1) as f64;
        // `scale` is finite and non-negative (0 when `max` is 0 or not finite), so
        // `value * scale` is monotone in the value.
        let scale = if max > 0.0 && max.is_finite() {
            top / max
        } else {
            0.0
        };
        DistanceSort {
            scale,
            ends: vec![0; buckets],
        }
    }

    #[inline]
    fn bucket_of(&self, bits: u64) -> usize {
        // The saturating cast maps NaN to 0 and the clamp keeps large values in range.
        ((f64::from_bits(bits) * self.scale) as usize).min(self.ends.len() - 1)
    }

    /// First pass: count one pair's distance.
    #[inline]
    pub(crate) fn count(&mut self, bits: u64) {
        let b = self.bucket_of(bits);
        self.ends[b] += 1;
    }

    /// Second pass: the counted pairs (the same distances, in any order), sorted.
    pub(crate) fn place(mut self, pairs: impl Iterator<Item = (u64, u32)>) -> Vec<(u64, u32)> {
        // Counts become starts.
        let mut sum = 0u32;
        for e in self.ends.iter_mut() {
            let here = *e;
            *e = sum;
            sum = sum.wrapping_add(here);
        }
        let n = sum as usize;
        let mut out = vec![(0u64, 0u32); n];
        for e in pairs {
            let b = self.bucket_of(e.0);
            let at = &mut self.ends[b];
            if let Some(slot) = out.get_mut(*at as usize) {
                *slot = e;
            }
            *at += 1;
        }
        // Starts have become ends; bucket b is `ends[b - 1]..ends[b]`.
        let mut from = 0usize;
        for &end in &self.ends {
            let end = (end as usize).min(n);
            let run = &mut out[from.min(end)..end];
            from = end;
            if run.len() <= 16 {
                for i in 1..run.len() {
                    let mut j = i;
                    while j > 0 && run[j] < run[j - 1] {
                        run.swap(j, j - 1);
                        j -= 1;
                    }
                }
            } else {
                run.sort_unstable();
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn distance_sort_matches_a_comparison_sort() {
        let mut x = 777u64;
        let mut next = || {
            x = x
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            x >> 11
        };
        let cases: Vec<Vec<f64>> = vec![
            vec![],
            vec![0.3],
            vec![0.0; 100],
            (0..5000).map(|_| (next() % 1000) as f64 / 1333.0).collect(),
            (0..3000).map(|_| (next() % 7) as f64 * 0.1).collect(),
            (0..2000)
                .map(|i| {
                    if i % 500 == 0 {
                        f64::INFINITY
                    } else {
                        (next() % 100) as f64
                    }
                })
                .collect(),
            (0..2000)
                .map(|i| {
                    if i == 7 {
                        1e300
                    } else {
                        (next() % 1000) as f64 * 1e-6
                    }
                })
                .collect(),
            (0..2000).map(|_| f64::from_bits(next() >> 2)).collect(),
        ];
        for d in cases {
            let mut v: Vec<(u64, u32)> = d
                .iter()
                .enumerate()
                .map(|(i, &d)| (d.to_bits(), (i as u32).wrapping_mul(2654435761) % 100_000))
                .collect();
            let mut want = v.clone();
            want.sort();
            // Buckets over a fixed range that may be far too small or too large.
            for max in [0.75, 1e-9, 1e9] {
                let mut sort = DistanceSort::new(v.len(), max);
                for e in &v {
                    sort.count(e.0);
                }
                assert_eq!(sort.place(v.iter().rev().copied()), want);
            }
            sort_by_distance(&mut v);
            assert_eq!(v, want);
        }
    }
}
