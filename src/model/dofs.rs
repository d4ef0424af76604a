//! The one place that knows where each degree of freedom lives.
//!
//! Full configuration vector (length `4N - 1`): node positions first, node-major
//! (`x_i` component `k` at `3 i + k`), then the edge twist angles (`theta^j` at `3 N + j`).
//! The clamp fixes `x_0`, `x_1` and `theta^0`; the free unknowns are
//! `u = (x_2 .. x_{N-1}, theta^1 .. theta^{N-2})` in that order.

/// Index map between the full configuration vector and the free unknowns.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Layout {
    nodes: usize,
}

impl Layout {
    /// Number of clamped nodes (`x_0`, `x_1`).
    pub(crate) const CLAMPED_NODES: usize = 2;

    pub fn new(nodes: usize) -> Self {
        assert!(nodes >= 3, "a rod needs at least three nodes");
        Layout { nodes }
    }

    /// Number of nodes `N`.
    pub fn nodes(&self) -> usize {
        self.nodes
    }

    /// Number of edges `N - 1`.
    pub fn edges(&self) -> usize {
        self.nodes - 1
    }

    /// Length of the full configuration vector, `4N - 1`.
    pub fn full_len(&self) -> usize {
        4 * self.nodes - 1
    }

    /// Full index of component `k` of node `i`.
    pub fn x(&self, i: usize, k: usize) -> usize {
        3 * i + k
    }

    /// Full index of the twist angle of edge `j`.
    pub fn theta(&self, j: usize) -> usize {
        3 * self.nodes + j
    }

    /// Number of free position unknowns, `3 (N - 2)`.
    pub fn free_positions(&self) -> usize {
        3 * (self.nodes - Self::CLAMPED_NODES)
    }

    /// The largest distance between corresponding free nodes of two vectors of free unknowns
    /// (their positions; the twist is not compared): how far one state of the rod lies from
    /// another.
    pub fn node_distance(&self, a: &[f64], b: &[f64]) -> f64 {
        let nx = self.free_positions();
        a[..nx]
            .chunks_exact(3)
            .zip(b[..nx].chunks_exact(3))
            .map(|(p, q)| {
                p.iter()
                    .zip(q)
                    .map(|(x, y)| (x - y) * (x - y))
                    .sum::<f64>()
                    .sqrt()
            })
            .fold(0.0, f64::max)
    }

    /// Number of free unknowns, `4 N - 8`.
    pub(crate) fn free_len(&self) -> usize {
        self.free_positions() + self.nodes - 2
    }

    /// Full index of each free unknown, in the order of `u`.
    pub(crate) fn free_indices(&self) -> Vec<usize> {
        (self.x(Self::CLAMPED_NODES, 0)..3 * self.nodes)
            .chain(self.theta(1)..self.full_len())
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn free_indices_skip_the_clamp() {
        let layout = Layout::new(5);
        let free = layout.free_indices();
        assert_eq!(free.len(), layout.free_len());
        assert_eq!(free.len(), 12);
        assert_eq!(free[0], 6);
        assert_eq!(free[8], 14);
        assert_eq!(free[9], layout.theta(1));
        assert_eq!(*free.last().unwrap(), layout.full_len() - 1);
    }
}
