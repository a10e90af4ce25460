//! The items of an image whose pixels have samples of their own (a noise
//! target's allocation): pixel `p` traces its samples `first[p] ..
//! first[p] + count[p]` in this unit (a shard's part of the pixel's
//! allocation). The items are ordered by *level*: item order first visits
//! sample `first[p]` of every pixel with a count above 0, in pixel order,
//! then sample `first[p] + 1` of every pixel with a count above 1, and so
//! on. Every item is a traced path, any range of items is a wave, and every
//! pixel adds its samples in order, so the sums do not depend on how the
//! items are cut into waves (checkpoints) or threads.

/// A unit's samples per pixel, and where its items fall.
#[derive(Debug, Clone, PartialEq)]
pub struct PixelCounts {
    /// Per pixel: its first sample in this unit.
    first: Vec<u64>,
    /// Per pixel: its samples in this unit (0: not traced).
    count: Vec<u64>,
    /// Per pixel: its samples in the whole task (which stratify its
    /// samples the same in every shard).
    total: Vec<u64>,
    /// The counts in ascending order, and their prefix sums (one longer).
    sorted: Vec<u64>,
    prefix: Vec<u64>,
}

impl PixelCounts {
    /// Pixel `p` traces samples `ranges[p]` of its `totals[p]`.
    pub fn new(ranges: &[std::ops::Range<u64>], totals: &[u64]) -> PixelCounts {
        let first: Vec<u64> = ranges.iter().map(|r| r.start).collect();
        let count: Vec<u64> = ranges.iter().map(|r| r.end - r.start).collect();
        let mut sorted = count.clone();
        sorted.sort_unstable();
        let mut prefix = Vec::with_capacity(sorted.len() + 1);
        let mut sum = 0u64;
        prefix.push(0);
        for &c in &sorted {
            sum += c;
            prefix.push(sum);
        }
        PixelCounts {
            first,
            count,
            total: totals.to_vec(),
            sorted,
            prefix,
        }
    }

    /// Items (traced paths) in all.
    pub fn items(&self) -> u64 {
        *self.prefix.last().unwrap_or(&0)
    }

    /// Pixels.
    pub fn pixels(&self) -> usize {
        self.count.len()
    }

    /// Pixel `p`'s samples in the whole task.
    pub fn total(&self, p: usize) -> u64 {
        self.total[p]
    }

    /// Items below level `j`: Σ min(count, j).
    fn below_level(&self, j: u64) -> u64 {
        let k = self.sorted.partition_point(|&c| c <= j);
        self.prefix[k] + j * (self.sorted.len() - k) as u64
    }

    /// Per pixel, the samples (counted from its first) among the items
    /// `0 .. x`.
    pub fn done_below(&self, x: u64) -> Vec<u64> {
        let x = x.min(self.items());
        // The level of item x: the largest j with below_level(j) ≤ x.
        let (mut lo, mut hi) = (0u64, self.sorted.last().copied().unwrap_or(0));
        while lo < hi {
            let mid = lo + (hi - lo).div_ceil(2);
            if self.below_level(mid) <= x {
                lo = mid;
            } else {
                hi = mid - 1;
            }
        }
        let j = lo;
        let mut rest = x - self.below_level(j);
        self.count
            .iter()
            .map(|&c| {
                if c > j {
                    let extra = u64::from(rest > 0);
                    rest -= extra;
                    j + extra
                } else {
                    c
                }
            })
            .collect()
    }

    /// Per pixel, the samples (absolute indices) of the items `range`.
    pub fn samples_of(&self, range: &std::ops::Range<u64>) -> Vec<std::ops::Range<u64>> {
        let (a, b) = (self.done_below(range.start), self.done_below(range.end));
        self.first
            .iter()
            .zip(a.iter().zip(&b))
            .map(|(&f, (&a, &b))| f + a..f + b)
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn any_cut_of_the_items_gives_every_pixel_its_samples_in_order() {
        let ranges = vec![3..8, 0..0, 10..11, 0..4, 7..7, 2..9];
        let totals: Vec<u64> = ranges.iter().map(|r| r.end + 1).collect();
        let counts = PixelCounts::new(&ranges, &totals);
        let n = counts.items();
        assert_eq!(n, 5 + 1 + 4 + 7);
        for cuts in [vec![0, n], vec![0, 1, 2, 3, 9, 10, n], (0..=n).collect::<Vec<_>>()] {
            let mut next: Vec<u64> = ranges.iter().map(|r| r.start).collect();
            for w in cuts.windows(2) {
                for (p, s) in counts.samples_of(&(w[0]..w[1])).iter().enumerate() {
                    assert_eq!(s.start, next[p], "cut {w:?} pixel {p}");
                    next[p] = s.end;
                }
            }
            let ends: Vec<u64> = ranges.iter().map(|r| r.end).collect();
            assert_eq!(next, ends);
        }
    }

    #[test]
    fn items_visit_the_pixels_level_by_level() {
        let counts = PixelCounts::new(&[0..2, 0..1, 0..3], &[2, 1, 3]);
        // Level 0: pixels 0, 1, 2; level 1: pixels 0, 2; level 2: pixel 2.
        let order: Vec<usize> = (0..counts.items())
            .map(|x| {
                let s = counts.samples_of(&(x..x + 1));
                s.iter().position(|r| !r.is_empty()).unwrap()
            })
            .collect();
        assert_eq!(order, vec![0, 1, 2, 0, 2, 2]);
    }
}
