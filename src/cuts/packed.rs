//! The height-based compact representation of many cuts (cyberworlds §V-A.2, Fig. 5).
//!
//! # How it works
//! A bank of cuts (the cuts of all vertices of an object, or of all sample points of a field)
//! stores, for every node, its height in 4 bits (two nodes per byte; heights 0–15 cover
//! `S ≤ 2^15`) and its value in a [`ValueEncoding`]: 1 bit for binary visibility (the paper's
//! VCF), or 8 or 16 bits of `[0, 1]` fixed point for cosine-folded self-visibility. Node
//! positions are implicit: walking a cut's heights from the left and adding `2^h` leaves per
//! node says where each node starts and where the cut ends, so the bank needs no per-node index
//! (the paper's saving over the 2-byte index of refs. \[5\], \[6\]) and no per-cut offset in a file: the
//! offsets are rebuilt, and the heights checked, on load ([`PackedCuts::from_parts`]).
//!
//! [`CutView`] reads a cut from a bank or from a plain [`Cut`] alike; the walks in
//! [`super::walk`] take views.

use super::CutsError;
use super::cut::{Cut, CutNode};
use super::tree::check_levels;

/// How node values are stored.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum ValueEncoding {
    /// One bit per node: values exactly 0 or 1 (binary visibility, §V-A.1).
    Bits,
    /// `round(v·255)` in a byte, `v ∈ [0, 1]` (error ≤ 1/510).
    Unorm8,
    /// `round(v·65535)` in two bytes, `v ∈ [0, 1]` (error ≤ 1/131070).
    Unorm16,
}

impl ValueEncoding {
    /// Bits per stored value.
    pub fn bits(self) -> usize {
        match self {
            ValueEncoding::Bits => 1,
            ValueEncoding::Unorm8 => 8,
            ValueEncoding::Unorm16 => 16,
        }
    }

    /// The code in a file.
    pub(crate) fn code(self) -> u8 {
        match self {
            ValueEncoding::Bits => 1,
            ValueEncoding::Unorm8 => 8,
            ValueEncoding::Unorm16 => 16,
        }
    }

    /// The encoding of a file code.
    pub(crate) fn from_code(code: u8) -> Option<Self> {
        match code {
            1 => Some(ValueEncoding::Bits),
            8 => Some(ValueEncoding::Unorm8),
            16 => Some(ValueEncoding::Unorm16),
            _ => None,
        }
    }
}

/// Many cuts of one tree in the height-based representation.
#[derive(Clone, Debug, PartialEq)]
pub struct PackedCuts {
    levels: u32,
    encoding: ValueEncoding,
    /// First node of each cut, plus the total node count at the end.
    offsets: Vec<usize>,
    /// Heights, two per byte (low nibble first).
    heights: Vec<u8>,
    /// Values in `encoding` (bits low first; 16-bit values little-endian).
    values: Vec<u8>,
}

impl PackedCuts {
    /// An empty bank.
    pub fn new(levels: u32, encoding: ValueEncoding) -> Result<Self, CutsError> {
        check_levels(levels)?;
        Ok(Self { levels, encoding, offsets: vec![0], heights: Vec::new(), values: Vec::new() })
    }

    /// Depth of the tree.
    pub fn levels(&self) -> u32 {
        self.levels
    }

    /// Value encoding.
    pub fn encoding(&self) -> ValueEncoding {
        self.encoding
    }

    /// Number of cuts.
    pub fn len(&self) -> usize {
        self.offsets.len() - 1
    }

    /// True when the bank holds no cut.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Nodes over all cuts.
    pub fn node_count(&self) -> usize {
        self.offsets[self.len()]
    }

    /// Mean nodes per cut (0 for an empty bank).
    pub fn mean_cut_size(&self) -> f64 {
        if self.is_empty() { 0.0 } else { self.node_count() as f64 / self.len() as f64 }
    }

    /// Appends `cut`; its values must fit the encoding.
    pub fn push(&mut self, cut: &Cut) -> Result<(), CutsError> {
        if cut.levels() != self.levels {
            return Err(CutsError::LevelMismatch { index: self.len(), expected: self.levels, got: cut.levels() });
        }
        let quantised: Vec<u16> = cut.nodes().iter().enumerate().map(|(k, n)| self.quantise(k, n.value)).collect::<Result<_, _>>()?;
        let mut g = self.node_count();
        for (n, q) in cut.nodes().iter().zip(quantised) {
            if g.is_multiple_of(2) {
                self.heights.push(n.height);
            } else if let Some(last) = self.heights.last_mut() {
                *last |= n.height << 4;
            }
            match self.encoding {
                ValueEncoding::Bits if g.is_multiple_of(8) => self.values.push(q as u8),
                ValueEncoding::Bits => {
                    if let Some(last) = self.values.last_mut() {
                        *last |= (q as u8) << (g % 8);
                    }
                }
                ValueEncoding::Unorm8 => self.values.push(q as u8),
                ValueEncoding::Unorm16 => self.values.extend(q.to_le_bytes()),
            }
            g += 1;
        }
        self.offsets.push(g);
        Ok(())
    }

    fn quantise(&self, node: usize, value: f32) -> Result<u16, CutsError> {
        let encoding = self.encoding;
        match encoding {
            ValueEncoding::Bits if value == 0.0 || value == 1.0 => Ok(value as u16),
            ValueEncoding::Bits => Err(CutsError::Encoding { encoding, node, value, needs: "exactly 0 or 1" }),
            _ if !(0.0..=1.0).contains(&value) => Err(CutsError::Encoding { encoding, node, value, needs: "a number in [0, 1]" }),
            ValueEncoding::Unorm8 => Ok((value * 255.0).round() as u16),
            ValueEncoding::Unorm16 => Ok((value * 65535.0).round() as u16),
        }
    }

    /// Height of node `g` (global index).
    #[inline]
    fn height_at(&self, g: usize) -> u32 {
        ((self.heights[g >> 1] >> ((g & 1) * 4)) & 0x0F) as u32
    }

    /// Value of node `g` (global index).
    #[inline]
    fn value_at(&self, g: usize) -> f32 {
        match self.encoding {
            ValueEncoding::Bits => ((self.values[g >> 3] >> (g & 7)) & 1) as f32,
            ValueEncoding::Unorm8 => self.values[g] as f32 * (1.0 / 255.0),
            ValueEncoding::Unorm16 => u16::from_le_bytes([self.values[2 * g], self.values[2 * g + 1]]) as f32 * (1.0 / 65535.0),
        }
    }

    /// A view of cut `k` (panics when `k ≥ len`, an internal index).
    pub fn view(&self, k: usize) -> CutView<'_> {
        let start = self.offsets[k];
        CutView { levels: self.levels, len: self.offsets[k + 1] - start, source: Source::Packed { bank: self, start } }
    }

    /// Cut `k` decoded.
    pub fn get(&self, k: usize) -> Cut {
        let v = self.view(k);
        Cut::from_nodes_unchecked(self.levels, (0..v.len()).map(|i| CutNode { height: v.height(i) as u8, value: v.value(i) }).collect())
    }

    /// Bytes of the heights and values (what the representation stores).
    pub fn stored_bytes(&self) -> usize {
        self.heights.len() + self.values.len()
    }

    /// Bytes the same cuts take with a 2-byte node index per node instead of a 4-bit height and
    /// one offset per cut, the representation of the earlier methods, refs. \[5\], \[6\] (§V-A.2).
    pub fn index_representation_bytes(&self) -> usize {
        2 * self.node_count() + self.values.len() + 4 * self.len()
    }

    /// Each cut's first node, then the node count (the compute pass's layout, `super::flat`).
    pub(crate) fn offsets(&self) -> &[usize] {
        &self.offsets
    }

    /// The raw parts `(heights, values)`, for files.
    pub(crate) fn raw(&self) -> (&[u8], &[u8]) {
        (&self.heights, &self.values)
    }

    /// Rebuilds a bank of `cuts` cuts and `nodes` nodes from raw parts, checking every cut's
    /// heights (aligned nodes covering each leaf once) and the parts' lengths.
    pub fn from_parts(levels: u32, encoding: ValueEncoding, cuts: usize, nodes: usize, heights: Vec<u8>, values: Vec<u8>) -> Result<Self, CutsError> {
        check_levels(levels)?;
        // Every cut has a node: more cuts than nodes is a bad header (checked before allocating).
        if cuts > nodes || nodes > 2 * heights.len() {
            return Err(CutsError::InvalidCut { levels, reason: format!("{cuts} cuts of {nodes} nodes in {} height bytes", heights.len()) });
        }
        let value_bytes = (nodes * encoding.bits()).div_ceil(8);
        if heights.len() != nodes.div_ceil(2) || values.len() != value_bytes {
            return Err(CutsError::InvalidCut { levels, reason: format!("{nodes} nodes need {} height bytes and {value_bytes} value bytes, got {} and {}", nodes.div_ceil(2), heights.len(), values.len()) });
        }
        let mut bank = Self { levels, encoding, offsets: Vec::with_capacity(cuts + 1), heights, values };
        bank.offsets.push(0);
        let total = 1u64 << levels;
        let (mut g, mut covered) = (0usize, 0u64);
        while g < nodes {
            let h = bank.height_at(g);
            if h > levels || covered % (1u64 << h) != 0 {
                return Err(CutsError::InvalidCut { levels, reason: format!("cut {} node {} has height {h} at leaf {covered}", bank.len(), g - bank.offsets[bank.len()]) });
            }
            covered += 1u64 << h;
            g += 1;
            if covered == total {
                bank.offsets.push(g);
                covered = 0;
            }
        }
        if covered != 0 || bank.len() != cuts {
            return Err(CutsError::InvalidCut { levels, reason: format!("the heights make {} whole cuts (+{covered} leaves), the header says {cuts}", bank.len()) });
        }
        Ok(bank)
    }
}

#[derive(Clone, Copy, Debug)]
enum Source<'a> {
    Plain(&'a [CutNode]),
    Packed { bank: &'a PackedCuts, start: usize },
}

/// Read access to one cut, plain or packed.
#[derive(Clone, Copy, Debug)]
pub struct CutView<'a> {
    levels: u32,
    len: usize,
    source: Source<'a>,
}

impl<'a> CutView<'a> {
    /// Depth of the tree.
    #[inline]
    pub fn levels(&self) -> u32 {
        self.levels
    }

    /// Number of nodes.
    #[inline]
    pub fn len(&self) -> usize {
        self.len
    }

    /// Never true for a valid cut.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Height of node `i`.
    #[inline]
    pub fn height(&self, i: usize) -> u32 {
        match self.source {
            Source::Plain(nodes) => nodes[i].height as u32,
            Source::Packed { bank, start } => bank.height_at(start + i),
        }
    }

    /// Value of node `i`.
    #[inline]
    pub fn value(&self, i: usize) -> f32 {
        match self.source {
            Source::Plain(nodes) => nodes[i].value,
            Source::Packed { bank, start } => bank.value_at(start + i),
        }
    }
}

impl Cut {
    /// A view for the walks.
    pub fn view(&self) -> CutView<'_> {
        CutView { levels: self.levels(), len: self.len(), source: Source::Plain(self.nodes()) }
    }
}
