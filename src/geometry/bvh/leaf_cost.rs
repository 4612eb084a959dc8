//! What the SAH build counts a leaf as costing: as the walk that will test
//! its triangles does.

/// What testing a leaf costs, as the walk that will test it counts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum LeafCost {
    /// A single ray tests a leaf's triangles four at a time (`Triangle4`):
    /// the packets of four that they fill.
    Packets,
    /// A packet of rays tests them one at a time, each against all its
    /// rays (`Bvh::intersect_packet`): the triangles.
    Triangles,
}

impl LeafCost {
    pub(super) fn of(self, n: usize) -> f32 {
        match self {
            LeafCost::Packets => n.div_ceil(4) as f32,
            LeafCost::Triangles => n as f32,
        }
    }

    /// Leaves of at most this many primitives are never split: for
    /// single rays one packet of four (which the SAH would never split),
    /// for packets one triangle.
    pub(super) fn never_split(self) -> usize {
        match self {
            LeafCost::Packets => 4,
            LeafCost::Triangles => 1,
        }
    }
}
