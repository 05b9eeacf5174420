//! A precomputed nearest-wall-point index: a raster over the plan's extent whose every cell lists
//! the only wall points that can be nearest to a query inside it.
//!
//! For a cell with centre `c`, half-diagonal `r` and nearest wall point at distance `d(c)`, any
//! query `q` in the cell has its nearest wall point within `d(c) + r` of `q`, hence within
//! `d(c) + 2r` of `c`. The cell lists exactly the points within that radius of its centre, so the
//! nearest of them is the exact nearest wall point of `q` (the same answer as a KD-tree). A point
//! of that list that another one is at least as near to at all four corners of the cell is
//! dropped: it is nowhere in the cell strictly nearer, so the lists keep only the points whose
//! Voronoi regions meet the cell (one or two along a straight wall).
//! Cells farther than `reach + r` from every wall hold no list: every query there is more than
//! `reach` from the plan, and the index answers "no wall point within reach". A look-up is one
//! cell address and a scan of a handful of candidates (a few nanoseconds), against 200-300 ns for
//! a KD-tree query.
//!
//! Memory is bounded by the band of cells within `reach` of the walls: cells are grouped in
//! blocks of [`BLOCK`] x [`BLOCK`], and only blocks that reach a wall are stored, at 8 bytes per
//! cell: the one or two plan points whose Voronoi regions meet the cell (nearly every cell), or the
//! offset of a longer list (4 bytes per candidate plus a 4-byte length). The index keeps its own
//! copy of the wall points with the directions they can be seen from and their plan indices
//! (24 bytes per point), so that a look-up touches only the index. [`NearestWallIndex::memory_bytes`] reports
//! the total.
//!
//! A look-up has no data-dependent branch in the common case: an empty block or cell points at a
//! sentinel point infinitely far away, and a single candidate is stored twice. A scan's look-ups
//! ([`NearestWallIndex::find_pairs`]) run in three passes (cells, their slots, their sites), so
//! that the reads of one pass are independent of one another and overlap: 7.4 ns per point against
//! 13.5 ns when each point's three dependent reads ran one after the other (`cargo bench`,
//! `correspondences_1080/wall_index`, 8.0 against 14.5 µs).
//!
//! Build: one KD-tree radius query per block (all points that can matter to any of its cells,
//! sorted by distance to the block centre), then for every cell the exact nearest distance and
//! its list from that short, sorted prefix.
//!
//! This file holds the index's layout and sizes; its submodules build it (`construction`), answer
//! look-ups from it (`look_up`), and tell from which direction the sensor sees each scan point
//! ([`SensorView`], `sensor_view`).

mod construction;
mod look_up;
mod sensor_view;

pub use sensor_view::SensorView;

/// Cells per block side.
pub const BLOCK: usize = 8;
const BLOCK_CELLS: usize = BLOCK * BLOCK;
/// Marks a block with no wall within reach (before the build ends: then it points at the empty
/// block 0).
const EMPTY: u32 = u32::MAX;
/// Set in a cell's first slot when the second holds the offset of a list.
const LIST: u32 = 1 << 31;
/// How far beyond a cell's nearest wall point its alternative is looked for, metres (the
/// thickest wall whose near face stands in for its far one).
pub const ALTERNATIVE_REACH: f64 = 0.45;
/// Largest plan an index can hold (one index is the sentinel, one bit marks lists).
pub const MAX_INDEX_POINTS: usize = (LIST - 1) as usize;
/// Most cells (stored or not) an index may span: larger plans need a coarser cell
/// (see [`cell_within_budget`]). The block table then takes at most 16 MiB.
pub const MAX_INDEX_CELLS: f64 = (1u64 << 28) as f64;

/// `cell`, or the smallest cell that keeps an index of a plan spanning `extent` (metres, x and y)
/// within [`MAX_INDEX_CELLS`] with `reach`.
pub fn cell_within_budget(cell: f64, extent: [f64; 2], reach: f64) -> f64 {
    let mut cell = cell;
    let cells = |c: f64| {
        let m = 2.0 * (reach + c);
        ((extent[0] + m) / c / BLOCK as f64 + 1.0)
            * ((extent[1] + m) / c / BLOCK as f64 + 1.0)
            * BLOCK_CELLS as f64
    };
    while cells(cell) > MAX_INDEX_CELLS {
        cell *= 1.25;
    }
    cell
}

/// A wall point as the index stores it.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Site {
    x: f64,
    y: f64,
    /// Sectors it can be seen from, see [`crate::visibility::wall_facing`].
    seen: u16,
    /// Its index in the plan (a placeholder for the sentinel). In the padding after `seen`: a
    /// pair's target costs no further read.
    plan: u32,
}

/// Exact nearest-wall-point look-ups within a fixed reach, from a precomputed raster.
#[derive(Debug, Clone)]
pub struct NearestWallIndex {
    origin: [f64; 2],
    cell: f64,
    inv_cell: f64,
    reach: f64,
    cols: usize,
    rows: usize,
    block_cols: usize,
    /// Per block (row-major): its number among the stored blocks (0: the empty block).
    blocks: Vec<u32>,
    /// Per stored block, `BLOCK_CELLS` cells (row-major) of two site indices (the sentinel
    /// `sites.len() - 1` when none), or `[LIST | length, offset]` of a list in `lists`; then the
    /// cell's alternative: the site nearest to the cell among those seen from a direction the
    /// nearest one is hidden from (the near face of a wall whose far face is nearest).
    /// (While building: the three slots of every cell; split into `slots` and `alternatives`.)
    building: Vec<[u32; 3]>,
    /// The first two slots of every cell.
    slots: Vec<[u32; 2]>,
    /// The third: read only when the nearest point is hidden.
    alternatives: Vec<u32>,
    lists: Vec<u32>,
    /// The wall points in the order cells first name them (neighbours in the plan are
    /// neighbours in memory), and, last, the sentinel. Slots and lists index into it.
    sites: Vec<Site>,
}

/// Sizes of a built index.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IndexStats {
    /// Cells across the plan's extent (columns times rows).
    pub cells: usize,
    /// Blocks stored (those within reach of a wall), of all blocks.
    pub stored_blocks: usize,
    /// All blocks.
    pub blocks: usize,
    /// Candidates over all stored cells.
    pub candidates: usize,
    /// Bytes held by the index.
    pub memory_bytes: usize,
}
impl NearestWallIndex {
    /// Cell size, metres.
    pub fn cell(&self) -> f64 {
        self.cell
    }

    /// Largest distance from the walls at which look-ups are answered, metres.
    pub fn reach(&self) -> f64 {
        self.reach
    }

    /// Sizes and memory of the index.
    pub fn stats(&self) -> IndexStats {
        let stored_blocks = self.slots.len() / BLOCK_CELLS - 1;
        let sentinel = (self.sites.len() - 1) as u32;
        let candidates = self.slots[BLOCK_CELLS..]
            .iter()
            .map(|s| match *s {
                [a, _] if a & LIST != 0 => (a & !LIST) as usize,
                [a, _] if a == sentinel => 0,
                [a, b] => 1 + usize::from(a != b),
            })
            .sum();
        IndexStats {
            cells: self.cols * self.rows,
            stored_blocks,
            blocks: self.blocks.len(),
            candidates,
            memory_bytes: self.memory_bytes(),
        }
    }

    /// Bytes held by the index (tables and candidates).
    pub fn memory_bytes(&self) -> usize {
        std::mem::size_of::<Self>()
            + self.blocks.len() * 4
            + self.slots.len() * 8
            + self.alternatives.len() * 4
            + self.lists.len() * 4
            + self.sites.len() * std::mem::size_of::<Site>()
    }
}

/// The cell of a raster coordinate `f` (cells) in `[0, 2^31)`: `f - 0.5` rounded to the nearest
/// integer by the float unit itself (adding 1.5 * 2^52 leaves the integer in the low mantissa
/// bits). A point exactly on a cell border lands in either neighbour; both hold it in their closed
/// square, which is all the lists promise. Two instructions, against the dozen of a saturating
/// `as usize` cast.
#[inline]
fn cell_index(f: f64) -> usize {
    const ROUNDING: f64 = 6_755_399_441_055_744.0;
    ((f - 0.5 + ROUNDING).to_bits() & 0xFFFF_FFFF) as usize
}

#[cfg(test)]
mod tests;
