//! The device memory a GPU engine will allocate, buffer by buffer, computed on the host
//! from the case and its counts before any buffer is made: `meshless check` and `run
//! --explain` give it, and a run or check past the device's memory is refused by it. Each
//! engine's set-up has a `memory` function beside it that sizes its buffers from the same
//! layouts ([`Fields`]) and rules as the set-up, under the labels the set-up books them by
//! ([`crate::gpu::Gpu::allocations`]), so a test holds the two to each other.

use super::layout::Fields;

/// What a case's buffers are sized by, estimated from its keys before it is built
/// (`run::Estimate`), or counted on a built case.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Counts {
    /// Particles, or the nodes of a Galerkin method.
    pub particles: f64,
    /// Neighbour pairs within the case kernel's support.
    pub pairs: f64,
    /// Cells of the lattice between the particles (a Galerkin method integrates over them).
    pub cells: f64,
    /// Pairs of the cells' two-point Gauss points with the particles within the support.
    pub gauss_pairs: f64,
    /// Pairs of the cells' centres with the particles within the support.
    pub centre_pairs: f64,
    /// Pairs of the particles and of the cells' centres with the particles of their
    /// candidate boxes (`ul-weak-form`).
    pub box_pairs: f64,
    pub centre_box_pairs: f64,
    /// Mirror particles of the symmetry planes.
    pub ghosts: f64,
}

impl Counts {
    /// Counts whose buffers' sizes pass any device: the buffers are then infinite, not a
    /// wrapped `usize`.
    const TOO_MANY: f64 = (1u64 << 40) as f64;

    /// Whether every count is a size a layout may be built on.
    fn fits(&self) -> bool {
        [
            self.particles,
            self.pairs,
            self.cells,
            self.gauss_pairs,
            self.centre_pairs,
            self.box_pairs,
            self.centre_box_pairs,
            self.ghosts,
        ]
        .iter()
        .all(|c| c.is_finite() && *c < Self::TOO_MANY)
    }

    /// The particles, as a layout's count.
    pub fn n(&self) -> usize {
        self.particles.round() as usize
    }

    /// The neighbour pairs, as a layout's count.
    pub fn pair_count(&self) -> usize {
        self.pairs.round() as usize
    }

    /// A count as a layout takes it.
    pub fn whole(count: f64) -> usize {
        count.round() as usize
    }
}

/// The buffers of an engine, bytes by ledger label, in the order they were added (the
/// bytes of rows sharing a label add up, as the ledger's do).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct DeviceMemory {
    rows: Vec<(&'static str, f64)>,
}

impl DeviceMemory {
    /// The memory of an engine sized by `build` on `counts`, or infinite for counts no
    /// device holds.
    pub fn of(counts: &Counts, build: impl FnOnce(&mut Self)) -> Self {
        let mut memory = Self::default();
        if counts.fits() {
            build(&mut memory);
        } else {
            memory.add("all buffers", f64::INFINITY);
        }
        memory
    }

    /// Books `bytes` under `label`: at least 4, a multiple of 4, as the device's buffers.
    pub fn add(&mut self, label: &'static str, bytes: f64) {
        let bytes = (bytes / 4.0).ceil().max(1.0) * 4.0;
        match self.rows.iter_mut().find(|(l, _)| *l == label) {
            Some((_, b)) => *b += bytes,
            None => self.rows.push((label, bytes)),
        }
    }

    /// Books a buffer of the layout `fields` under `label`.
    pub fn fields(&mut self, label: &'static str, fields: &Fields) {
        self.add(label, fields.bytes() as f64);
    }

    /// Books `count` words of 4 bytes under `label`.
    pub fn words(&mut self, label: &'static str, count: f64) {
        self.add(label, 4.0 * count);
    }

    /// The rows, bytes by label.
    pub fn rows(&self) -> &[(&'static str, f64)] {
        &self.rows
    }

    /// The bytes of every buffer.
    pub fn total(&self) -> f64 {
        self.rows.iter().map(|(_, b)| b).sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rows_round_as_buffers_and_add_by_label() {
        // 10 bytes make a 12-byte buffer, an empty one 4; two rows of one label add up.
        let counts = Counts {
            particles: 10.0,
            pairs: 0.0,
            cells: 0.0,
            gauss_pairs: 0.0,
            centre_pairs: 0.0,
            box_pairs: 0.0,
            centre_box_pairs: 0.0,
            ghosts: 0.0,
        };
        let m = DeviceMemory::of(&counts, |m| {
            m.add("a", 10.0);
            m.add("b", 0.0);
            m.words("a", 2.0);
        });
        assert_eq!(m.rows(), &[("a", 20.0), ("b", 4.0)]);
        assert_eq!(m.total(), 24.0);
        // Counts past any device give an infinite total, never a wrapped size.
        let huge = Counts {
            particles: 1e300,
            ..counts
        };
        assert_eq!(
            DeviceMemory::of(&huge, |_| unreachable!()).total(),
            f64::INFINITY
        );
    }
}
