//! Shards: a task's samples split into `N` disjoint, deterministic ranges,
//! so one task can run as `N` independent work units (`--shard K/N`, K from
//! 1) whose sums add up to the whole task's.
//!
//! Every sample has a fixed index and its own random stream (see
//! [`crate::sampling::sampler`]), so a shard is just a range of sample indices: for a
//! `directions` sensor a range of whole sample blocks (the unit of parallel
//! work, [`crate::film::tally::BLOCK`]), for an image a range of samples per pixel.
//! Range `K` of `N` over `n` items is `[⌊(K−1)·n/N⌋, ⌊K·n/N⌋)`: the ranges
//! tile `[0, n)` without overlap whatever `n` and `N` are (a shard may be
//! empty when `N > n`).

use std::fmt;
use std::ops::Range;
use std::str::FromStr;

/// Shard `index` (1-based) of `count`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Shard {
    pub index: u64,
    pub count: u64,
}

impl Shard {
    /// The whole task: shard 1 of 1.
    pub const WHOLE: Shard = Shard { index: 1, count: 1 };

    /// Shard `index` of `count`; `None` unless 1 ≤ index ≤ count.
    pub fn new(index: u64, count: u64) -> Option<Shard> {
        (index >= 1 && index <= count).then_some(Shard { index, count })
    }

    /// This shard's part of `[0, n)`.
    pub fn range(&self, n: u64) -> Range<u64> {
        let at = |k: u64| ((k as u128 * n as u128) / self.count as u128) as u64;
        at(self.index - 1)..at(self.index)
    }

    /// True for shard 1 of 1.
    pub fn is_whole(&self) -> bool {
        self.count == 1
    }

    /// The file-name form, zero-padded so names sort in shard order:
    /// `0003-of-0008`.
    pub fn file_stem(&self) -> String {
        format!("{:04}-of-{:04}", self.index, self.count)
    }
}

impl fmt::Display for Shard {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

/// Why a `K/N` shard string was refused.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ShardSyntax(pub String);

impl fmt::Display for ShardSyntax {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "`{}` is not a shard: expected K/N with whole numbers 1 ≤ K ≤ N (e.g. 3/8)",
            self.0
        )
    }
}

impl std::error::Error for ShardSyntax {}

impl FromStr for Shard {
    type Err = ShardSyntax;

    fn from_str(s: &str) -> Result<Shard, ShardSyntax> {
        let err = || ShardSyntax(s.to_string());
        let (k, n) = s.split_once('/').ok_or_else(err)?;
        let k: u64 = k.trim().parse().map_err(|_| err())?;
        let n: u64 = n.trim().parse().map_err(|_| err())?;
        Shard::new(k, n).ok_or_else(err)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranges_tile_without_overlap() {
        for n in [0u64, 1, 2, 7, 98, 1000, 1023, 1024] {
            for count in 1..=12u64 {
                let mut next = 0;
                for index in 1..=count {
                    let r = Shard { index, count }.range(n);
                    assert_eq!(r.start, next, "n {n} shard {index}/{count}");
                    assert!(r.end >= r.start);
                    next = r.end;
                }
                assert_eq!(next, n);
            }
        }
    }

    #[test]
    fn ranges_are_balanced() {
        let sizes: Vec<u64> = (1..=3)
            .map(|k| Shard { index: k, count: 3 }.range(10))
            .map(|r| r.end - r.start)
            .collect();
        assert_eq!(sizes, vec![3, 3, 4]);
        assert_eq!(Shard::WHOLE.range(12345), 0..12345);
    }

    #[test]
    fn parses_and_refuses() {
        assert_eq!("3/8".parse::<Shard>(), Ok(Shard { index: 3, count: 8 }));
        assert_eq!(" 1 / 1 ".parse::<Shard>(), Ok(Shard::WHOLE));
        for bad in ["0/4", "5/4", "3", "a/4", "3/0", "-1/4", "1/2/3", ""] {
            assert!(bad.parse::<Shard>().is_err(), "{bad}");
        }
        let msg = "9/4".parse::<Shard>().unwrap_err().to_string();
        assert!(msg.contains("1 ≤ K ≤ N"), "{msg}");
        assert_eq!(Shard { index: 3, count: 8 }.file_stem(), "0003-of-0008");
        assert_eq!(Shard { index: 3, count: 8 }.to_string(), "3/8");
    }
}
