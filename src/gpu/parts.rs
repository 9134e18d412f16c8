//! Neighbour lists split by rows into parts whose per-pair buffers each fit one storage
//! binding.
//!
//! A part is a run of consecutive particles (rows) with their pairs. Each part has its own
//! offsets, ids and per-pair buffers, the offsets counted from the part's first pair, and a
//! pass over the pairs is one dispatch a part, which binds that part's buffers and reads
//! the part's first particle and rows from the uniform `part` (`shaders/common/part.wgsl`).
//! A pair index is local to its part, so no index into the lists passes 2³² however many
//! pairs a scene has; the per-particle buffers, which any pass may read at a neighbour,
//! stay whole, each in one binding. One part is the unsplit run, and a split run computes
//! every pair's terms in the same order, so its results are the unsplit run's, bit for bit.

use super::context::{Gpu, GpuError, Pipeline};
use crate::core::neighbour::Csr;
use encase::ShaderType;

/// Consecutive rows of the neighbour lists and their pairs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Part {
    /// Its first row (particle).
    pub first: usize,
    pub rows: usize,
    /// Its first pair in the whole lists.
    pub start: usize,
    pub pairs: usize,
}

/// The uniform `part` of `shaders/common/part.wgsl`.
#[derive(ShaderType)]
struct PartUniform {
    first: u32,
    rows: u32,
}

/// The neighbour lists of a scene split into [`Part`]s.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Split {
    pub parts: Vec<Part>,
}

impl Split {
    /// The lists `csr` in one part.
    pub fn whole(csr: &Csr) -> Self {
        Self {
            parts: vec![Part {
                first: 0,
                rows: csr.len(),
                start: 0,
                pairs: csr.pair_count(),
            }],
        }
    }

    /// The lists `csr` in parts of consecutive rows whose per-pair buffers of
    /// `pair_bytes` a pair, ids and offsets each fit `limit` bytes: as many parts as the
    /// bytes need (or the fewest more that fit), cut where the pairs are evenly shared, so
    /// that the per-pair buffers, each laid out for the most pairs of a part, hold little
    /// room unused. Err: one particle's pairs alone exceed the limit (their bytes).
    pub fn plan(csr: &Csr, pair_bytes: u64, limit: u64) -> Result<Self, u64> {
        let per_pair = pair_bytes.max(4);
        let bytes =
            |rows: usize, pairs: usize| (pairs as u64 * per_pair).max((rows as u64 + 1) * 4);
        if let Some(row) = (0..csr.len())
            .map(|i| bytes(1, csr.offsets[i + 1] - csr.offsets[i]))
            .find(|&b| b > limit)
        {
            return Err(row);
        }
        let (rows, pairs) = (csr.len(), csr.pair_count());
        if rows == 0 {
            return Ok(Self::whole(csr));
        }
        let needed = |b: u64| b.div_ceil(limit) as usize;
        let mut k = needed(pairs as u64 * per_pair)
            .max(needed((rows as u64 + 1) * 4))
            .max(1);
        loop {
            // Part j ends at the first row boundary at or past ⌈(j + 1) pairs / k⌉.
            let mut cuts: Vec<usize> = (1..k)
                .map(|j| {
                    (csr.offsets
                        .partition_point(|&o| o < (j * pairs).div_ceil(k)))
                    .min(rows)
                })
                .collect();
            cuts.insert(0, 0);
            cuts.push(rows);
            cuts.dedup();
            let parts: Vec<Part> = cuts
                .windows(2)
                .map(|w| Part {
                    first: w[0],
                    rows: w[1] - w[0],
                    start: csr.offsets.get(w[0]).copied().unwrap_or(0),
                    pairs: csr.offsets.get(w[1]).copied().unwrap_or(0)
                        - csr.offsets.get(w[0]).copied().unwrap_or(0),
                })
                .collect();
            if parts.iter().all(|p| bytes(p.rows, p.pairs) <= limit) {
                return Ok(Self { parts });
            }
            // One row a part always fits: k grows at most to the rows.
            k += 1;
        }
    }

    /// [`Self::plan`] for the binding limit of `gpu`; Err names the bytes of the particle
    /// whose pairs alone exceed it.
    pub fn fitting(gpu: &Gpu, csr: &Csr, pair_bytes: u64) -> Result<Self, GpuError> {
        let limit = gpu.binding_limit();
        Self::plan(csr, pair_bytes, limit).map_err(|needed| GpuError::TooLarge {
            adapter: gpu.name(),
            what: "list part (one particle's pairs)",
            needed,
            limit,
        })
    }

    /// The most pairs of a part: each part's per-pair buffers are laid out for as many, so
    /// that one compiled layout serves every part.
    pub fn capacity(&self) -> usize {
        self.parts.iter().map(|p| p.pairs).max().unwrap_or(0)
    }

    pub fn is_whole(&self) -> bool {
        self.parts.len() == 1
    }

    /// Records one dispatch of `pipeline` a part, over its rows, with the part's bind
    /// group of `binds`.
    pub fn dispatch(
        &self,
        gpu: &Gpu,
        pass: &mut wgpu::ComputePass<'_>,
        pipeline: &Pipeline,
        binds: &[wgpu::BindGroup],
    ) {
        for (part, bind) in self.parts.iter().zip(binds) {
            gpu.dispatch(pass, pipeline, bind, part.rows as u32);
        }
    }

    /// Err where the lists are split and `pass` reads them whole (`offsets[i]` of any
    /// particle): its `pair_bytes` a pair of the whole lists must fit one binding.
    pub fn whole_for(
        &self,
        gpu: &Gpu,
        pass: &'static str,
        pair_bytes: u64,
    ) -> Result<(), GpuError> {
        if self.is_whole() {
            return Ok(());
        }
        let pairs: usize = self.parts.iter().map(|p| p.pairs).sum();
        Err(GpuError::TooLarge {
            adapter: gpu.name(),
            what: pass,
            needed: pairs as u64 * pair_bytes,
            limit: gpu.binding_limit(),
        })
    }
}

/// A part's lists on the device: its offsets (from its first pair), ids and uniform.
pub struct PartLists {
    pub offsets: wgpu::Buffer,
    pub ids: wgpu::Buffer,
    pub uniform: wgpu::Buffer,
}

impl PartLists {
    /// Uploads the lists of every part of `split` of `csr`.
    pub fn upload(gpu: &Gpu, csr: &Csr, split: &Split) -> Vec<Self> {
        split
            .parts
            .iter()
            .map(|&part| {
                // Lists of no rows (`Csr::default()`) have the one offset 0.
                let rows = csr
                    .offsets
                    .get(part.first..=part.first + part.rows)
                    .unwrap_or(&[0]);
                let offsets: Vec<u32> = rows.iter().map(|&o| (o - part.start) as u32).collect();
                let ids = &csr.ids[part.start..part.start + part.pairs];
                let uniform = PartUniform {
                    first: part.first as u32,
                    rows: part.rows as u32,
                };
                Self {
                    offsets: gpu.storage("neighbour offsets", &offsets),
                    ids: gpu.storage("neighbour ids", ids),
                    uniform: gpu.uniform("list part", &uniform),
                }
            })
            .collect()
    }

    /// The bindings `offsets`, `ids` and `part` of this part.
    pub fn table(&self) -> [(&'static str, &wgpu::Buffer); 3] {
        [
            ("offsets", &self.offsets),
            ("ids", &self.ids),
            ("part", &self.uniform),
        ]
    }
}

crate::gpu::context::wgsl_twin_test!(part_uniform_matches_wgsl: PartUniform = "Part" in include_str!("../../shaders/common/part.wgsl"));

#[cfg(test)]
mod tests {
    use super::*;

    fn csr(rows: &[usize]) -> Csr {
        Csr::from_rows(
            &rows
                .iter()
                .map(|&k| (0..k as u32).collect())
                .collect::<Vec<Vec<u32>>>(),
        )
    }

    /// Each part of `split` of `lists` follows the last, and fits `limit` at `bytes` a pair.
    fn cover(lists: &Csr, split: &Split, bytes: u64, limit: u64) {
        let mut next = (0, 0);
        for p in &split.parts {
            assert_eq!((p.first, p.start), next);
            assert!(p.pairs as u64 * bytes <= limit && (p.rows as u64 + 1) * 4 <= limit);
            assert_eq!(p.pairs, lists.offsets[p.first + p.rows] - p.start);
            next = (p.first + p.rows, p.start + p.pairs);
        }
        assert_eq!(next, (lists.len(), lists.pair_count()));
    }

    #[test]
    fn parts_cover_every_row_in_order_and_each_fits_the_limit() {
        let lists = csr(&[3, 5, 2, 0, 7, 4, 4, 1]);
        let split = Split::plan(&lists, 8, 64).unwrap();
        cover(&lists, &split, 8, 64);
        // 26 pairs of 8 B in 64 B parts: 4 parts at least, but no cut at the shares of 4 or
        // 5 parts fits (rows 2–4 hold 9 pairs); 6 parts at ⌈26 j / 6⌉ do.
        let pairs: Vec<usize> = split.parts.iter().map(|p| p.pairs).collect();
        assert_eq!(pairs, [8, 2, 7, 4, 4, 1]);
        assert_eq!(
            Split::plan(&lists, 8, 1 << 20).unwrap(),
            Split::whole(&lists)
        );
    }

    #[test]
    fn parts_share_the_pairs_evenly() {
        // 1,000 rows of 20 pairs, at most 300 rows a part: 4 parts of 250 rows, so that
        // the per-pair buffers, laid out for the most pairs of a part, waste nothing (a
        // greedy cut, 300 + 300 + 300 + 100 rows, would lay out 4 × 6,000 pairs for 20,000).
        let lists = csr(&[20; 1000]);
        let limit = 8 * 20 * 300 + 8;
        let split = Split::plan(&lists, 8, limit).unwrap();
        cover(&lists, &split, 8, limit);
        assert!(split.parts.iter().all(|p| p.rows == 250), "{split:?}");
        assert_eq!(split.capacity(), 5000);
    }

    #[test]
    fn a_row_past_the_limit_is_refused_with_its_bytes() {
        assert_eq!(Split::plan(&csr(&[2, 9]), 8, 64), Err(72));
    }
}
