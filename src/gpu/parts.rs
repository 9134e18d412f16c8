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

use super::context::{Gpu, GpuError, Pipeline, WORKGROUP};
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
    /// `pair_bytes` a pair, ids and offsets each fit `limit` bytes, each part starting at
    /// a multiple of `align` rows: as many parts as the bytes need (or the fewest more
    /// that fit), cut where the pairs are evenly shared, so that the per-pair buffers,
    /// each laid out for the most pairs of a part, hold little room unused. Err: the
    /// pairs of one block of `align` rows alone exceed the limit (their bytes).
    pub fn plan(csr: &Csr, pair_bytes: u64, limit: u64, align: usize) -> Result<Self, u64> {
        let per_pair = pair_bytes.max(4);
        let (rows, pairs) = (csr.len(), csr.pair_count());
        let align = align.max(1);
        let bytes = |first: usize, end: usize| {
            let pairs = csr.offsets[end] - csr.offsets[first];
            (pairs as u64 * per_pair).max((end - first + 1) as u64 * 4)
        };
        let blocks: Vec<usize> = (0..rows.div_ceil(align))
            .map(|b| b * align)
            .chain([rows])
            .collect();
        if let Some(block) = blocks
            .windows(2)
            .map(|w| bytes(w[0], w[1]))
            .find(|&b| b > limit)
        {
            return Err(block);
        }
        if rows == 0 {
            return Ok(Self::whole(csr));
        }
        let parts = |cuts: &[usize]| -> Vec<Part> {
            (cuts.windows(2))
                .map(|w| Part {
                    first: w[0],
                    rows: w[1] - w[0],
                    start: csr.offsets[w[0]],
                    pairs: csr.offsets[w[1]] - csr.offsets[w[0]],
                })
                .collect()
        };
        let fits =
            |parts: &[Part]| (parts.iter()).all(|p| bytes(p.first, p.first + p.rows) <= limit);
        let needed = |b: u64| b.div_ceil(limit) as usize;
        let least = needed(pairs as u64 * per_pair)
            .max(needed((rows as u64 + 1) * 4))
            .max(1);
        for k in least..blocks.len() - 1 {
            // Part j ends at the block boundary nearest ⌈(j + 1) pairs / k⌉.
            let mut cuts: Vec<usize> = (1..k)
                .map(|j| {
                    let row = csr
                        .offsets
                        .partition_point(|&o| o < (j * pairs).div_ceil(k));
                    ((row + align / 2) / align * align).min(rows)
                })
                .collect();
            cuts.insert(0, 0);
            cuts.push(rows);
            cuts.dedup();
            let split = parts(&cuts);
            if fits(&split) {
                return Ok(Self { parts: split });
            }
        }
        // A block a part, each of which fits.
        Ok(Self {
            parts: parts(&blocks),
        })
    }

    /// [`Self::plan`] for the binding limit of `gpu`, the parts starting at workgroup
    /// boundaries: a split run's workgroups are the unsplit run's, so that a pass that
    /// writes a partial result per workgroup writes the same partials a part at a time.
    /// Err names the bytes of the workgroup of particles whose pairs alone exceed it.
    pub fn fitting(gpu: &Gpu, csr: &Csr, pair_bytes: u64) -> Result<Self, GpuError> {
        let limit = gpu.binding_limit();
        Self::plan(csr, pair_bytes, limit, WORKGROUP as usize).map_err(|needed| {
            GpuError::TooLarge {
                adapter: gpu.name(),
                what: "list part (the pairs of one workgroup of particles)",
                needed,
                limit,
            }
        })
    }

    /// The most pairs of a part: each part's per-pair buffers are laid out for as many, so
    /// that one compiled layout serves every part.
    pub fn capacity(&self) -> usize {
        self.parts.iter().map(|p| p.pairs).max().unwrap_or(0)
    }

    /// The rows (particles) of every part.
    pub fn rows(&self) -> usize {
        self.parts.iter().map(|p| p.rows).sum()
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
        let parts = self.shares().map(|(rows, share)| (rows as u32, share));
        gpu.dispatch_parts(pass, pipeline, binds, parts);
    }

    /// The rows of each part and the share of the lists' pairs it holds (of the rows, for
    /// lists without pairs), for the pass report's bytes.
    pub fn shares(&self) -> impl ExactSizeIterator<Item = (usize, f64)> + '_ {
        let (pairs, rows) = (self.parts.iter().map(|p| p.pairs).sum(), self.rows());
        self.parts.iter().map(move |p| {
            let share = match pairs {
                0 => p.rows as f64 / rows.max(1) as f64,
                _ => p.pairs as f64 / pairs as f64,
            };
            (p.rows, share)
        })
    }
}

/// The uniform `part` of the `rows` particles from `first`.
pub fn uniform(gpu: &Gpu, first: usize, rows: usize) -> wgpu::Buffer {
    let part = PartUniform {
        first: first as u32,
        rows: rows as u32,
    };
    gpu.uniform("list part", &part)
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
                Self {
                    offsets: gpu.storage("neighbour offsets", &offsets),
                    ids: gpu.storage("neighbour ids", ids),
                    uniform: uniform(gpu, part.first, part.rows),
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
        let split = Split::plan(&lists, 8, 64, 1).unwrap();
        cover(&lists, &split, 8, 64);
        // 26 pairs of 8 B in 64 B parts: 4 parts at least, but no cut at the shares of 4 or
        // 5 parts fits (rows 2–4 hold 9 pairs); 6 parts at ⌈26 j / 6⌉ do.
        let pairs: Vec<usize> = split.parts.iter().map(|p| p.pairs).collect();
        assert_eq!(pairs, [8, 2, 7, 4, 4, 1]);
        assert_eq!(
            Split::plan(&lists, 8, 1 << 20, 1).unwrap(),
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
        let split = Split::plan(&lists, 8, limit, 1).unwrap();
        cover(&lists, &split, 8, limit);
        assert!(split.parts.iter().all(|p| p.rows == 250), "{split:?}");
        assert_eq!(split.capacity(), 5000);
    }

    #[test]
    fn a_row_past_the_limit_is_refused_with_its_bytes() {
        assert_eq!(Split::plan(&csr(&[2, 9]), 8, 64, 1), Err(72));
    }

    #[test]
    fn aligned_parts_start_at_a_block_and_a_block_past_the_limit_is_refused() {
        // At most 300 rows a part in blocks of 256: the even cuts at rows 250, 500 and
        // 750 move to the nearest block, 256, 512 and 768.
        let lists = csr(&[20; 1000]);
        let limit = 8 * 20 * 300 + 8;
        let split = Split::plan(&lists, 8, limit, 256).unwrap();
        cover(&lists, &split, 8, limit);
        let firsts: Vec<usize> = split.parts.iter().map(|p| p.first).collect();
        assert_eq!(firsts, [0, 256, 512, 768]);
        // A block of 256 rows holds 5,120 pairs: 40,960 B past a limit of 100 rows.
        assert_eq!(Split::plan(&lists, 8, 8 * 20 * 100, 256), Err(40_960));
    }
}
