//! Canvas positions for nodes a document places nowhere: a layered layout, columns by
//! dependency depth (a node one column right of its deepest source), each column ordered by
//! where its sources sit, nodes stacked by a nominal size with a gap, so no two overlap and
//! edges run left to right. A document whose nodes all have positions is left as it is; nodes
//! without one in a document that places others go below the placed ones.

use std::collections::BTreeMap;

use super::document::Graph;
use super::schema::{Catalog, NodeSchema};
use super::types::PortType;

/// Nominal width of a node on the canvas, in canvas units, at least (measured in the editor:
/// `SingleScattering`, nine inputs and a thumbnail, is ~290 wide; a long title widens a node:
/// see [`nominal_size`]).
pub const NODE_WIDTH: f32 = 320.0;
/// Space between two columns.
pub const COLUMN_GAP: f32 = 100.0;
/// Space between two nodes of a column.
pub const ROW_GAP: f32 = 40.0;

/// The nominal rectangle size (width, height) of node `id` of `schema` on the canvas: a title
/// bar (`id - Kind`, ~8 units a character), one row per port on its longer side, and a
/// thumbnail when it has a picture output — an upper bound of what the editor draws
/// (measured: 130–200 high, the composite of nine inputs 200), so that rectangles laid out
/// apart stay apart.
pub fn nominal_size(id: &str, schema: Option<&NodeSchema>) -> [f32; 2] {
    let title = id.chars().count() + 3 + schema.map_or(0, |s| s.kind.chars().count());
    let width = NODE_WIDTH.max(8.0 * title as f32 + 60.0);
    let Some(s) = schema else {
        return [width, 80.0];
    };
    let rows = s.inputs.len().max(s.outputs.len()).max(1) as f32;
    let picture = s.outputs.iter().any(|p| {
        p.types.iter().any(|t| {
            matches!(
                t,
                PortType::Image | PortType::Scalar | PortType::Depth | PortType::ShadowMap
            )
        })
    });
    [
        NODE_WIDTH,
        40.0 + 22.0 * rows + if picture { 110.0 } else { 0.0 },
    ]
}

impl Graph {
    /// Give every node without a canvas position one (see the module docs); returns how many
    /// were placed. Deterministic: the same document gets the same positions.
    pub fn place_unplaced(&mut self, catalog: &Catalog) -> usize {
        let order = self.topo_order();
        let unplaced: Vec<String> = order
            .iter()
            .filter(|id| self.node(id).is_some_and(|n| n.pos.is_none()))
            .cloned()
            .collect();
        if unplaced.is_empty() {
            return 0;
        }
        let size = |g: &Graph, id: &str| {
            nominal_size(id, g.node(id).and_then(|n| g.kind_schema(catalog, &n.kind)))
        };
        // The placed nodes' bounding box: the new ones go below it.
        let placed: Vec<([f32; 2], [f32; 2])> = self
            .nodes()
            .filter_map(|n| n.pos.map(|p| (p, size(self, &n.id))))
            .collect();
        let (x0, y0) = match placed.iter().map(|(p, _)| p[0]).reduce(f32::min) {
            Some(x) => {
                let bottom = placed
                    .iter()
                    .map(|(p, s)| p[1] + s[1])
                    .fold(f32::MIN, f32::max);
                (x, bottom + 2.0 * ROW_GAP)
            }
            None => (0.0, 0.0),
        };
        // Depth: one more than the deepest source (sources first in `order`).
        let edges = self.edges();
        let mut depth: BTreeMap<&str, usize> = BTreeMap::new();
        for id in &order {
            let d = edges
                .iter()
                .filter(|e| &e.to_node == id)
                .filter_map(|e| depth.get(e.from_node.as_str()).map(|d| d + 1))
                .max()
                .unwrap_or(0);
            depth.insert(id, d);
        }
        let mut columns: BTreeMap<usize, Vec<String>> = BTreeMap::new();
        for id in &unplaced {
            columns
                .entry(depth[id.as_str()])
                .or_default()
                .push(id.clone());
        }
        // Column by column, each ordered by the mean height of its sources' centres (the
        // columns to its left are placed by then), ties in topological order.
        let mut centre: BTreeMap<String, f32> = self
            .nodes()
            .filter_map(|n| {
                n.pos
                    .map(|p| (n.id.clone(), p[1] + size(self, &n.id)[1] / 2.0))
            })
            .collect();
        let mut placed_now = 0;
        // Each column as wide as its widest node.
        let mut x = x0;
        for (_, mut ids) in columns {
            let key = |id: &String| {
                let ys: Vec<f32> = edges
                    .iter()
                    .filter(|e| &e.to_node == id)
                    .filter_map(|e| centre.get(&e.from_node).copied())
                    .collect();
                if ys.is_empty() {
                    f32::MAX
                } else {
                    ys.iter().sum::<f32>() / ys.len() as f32
                }
            };
            let keys: BTreeMap<String, f32> = ids.iter().map(|id| (id.clone(), key(id))).collect();
            ids.sort_by(|a, b| keys[a].total_cmp(&keys[b]));
            let mut y = y0;
            let width = ids
                .iter()
                .map(|id| size(self, id)[0])
                .fold(NODE_WIDTH, f32::max);
            for id in ids {
                let h = size(self, &id)[1];
                centre.insert(id.clone(), y + h / 2.0);
                if self.set_pos(&id, Some([x, y])).is_ok() {
                    placed_now += 1;
                }
                y += h + ROW_GAP;
            }
            x += width + COLUMN_GAP;
        }
        placed_now
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Whether two nominal rectangles overlap.
    fn overlap(a: ([f32; 2], [f32; 2]), b: ([f32; 2], [f32; 2])) -> bool {
        a.0[0] < b.0[0] + b.1[0]
            && b.0[0] < a.0[0] + a.1[0]
            && a.0[1] < b.0[1] + b.1[1]
            && b.0[1] < a.0[1] + a.1[1]
    }

    #[test]
    fn nominal_sizes_grow_with_ports_and_pictures() {
        let small = nominal_size("c", None);
        assert_eq!(small[0], NODE_WIDTH);
        assert!(nominal_size("a_very_long_node_identifier_here", None)[0] > NODE_WIDTH);
        assert!(small[1] > 0.0);
        assert!(overlap(
            ([0.0, 0.0], [10.0, 10.0]),
            ([5.0, 5.0], [10.0, 10.0])
        ));
        assert!(!overlap(
            ([0.0, 0.0], [10.0, 10.0]),
            ([10.0, 0.0], [10.0, 10.0])
        ));
    }
}
