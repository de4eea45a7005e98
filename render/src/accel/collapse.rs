//! The 8-wide tree the traversal walks, made from pbrt-v3's binary SAH
//! tree, and how much stack a walk of it needs.

use super::bvh::LinearNode;
use super::node::{Node, WIDTH};

/// Collapses the binary tree `bin` into 8-wide nodes: each node takes its
/// binary children and keeps opening the interior one with the largest
/// surface area until it has eight. The root's children fill node 0.
pub(super) fn collapse(bin: &[LinearNode]) -> Vec<Node> {
    // Each wide node stands for at least one binary interior node; the
    // capacity not used is never touched, so it takes address space but no
    // memory (a small tree's is given back once it is built).
    let mut out = Vec::with_capacity(bin.len() / 2 + 1);
    if !bin.is_empty() {
        out.push(Node { b: [[0.0; WIDTH]; 6], child: [0; WIDTH], count: [0; WIDTH], n: 0 });
        fill(bin, 0, 0, &mut out);
    }
    out
}

fn fill(bin: &[LinearNode], b: usize, slot: usize, out: &mut Vec<Node>) {
    let mut lanes = [0usize; WIDTH];
    let mut n = if bin[b].is_leaf() {
        lanes[0] = b;
        1
    } else {
        lanes[..2].copy_from_slice(&[b + 1, bin[b].offset as usize]);
        2
    };
    while n < WIDTH {
        let widest = (0..n).filter(|&l| !bin[lanes[l]].is_leaf()).max_by(|&x, &y| {
            let (ax, ay) = (bin[lanes[x]].bounds(), bin[lanes[y]].bounds());
            ax.surface_area().total_cmp(&ay.surface_area())
        });
        let Some(l) = widest else { break };
        let c = lanes[l];
        lanes[l] = c + 1;
        lanes[n] = bin[c].offset as usize;
        n += 1;
    }
    // Empty lanes get an empty box as well as being masked off.
    let mut node = Node {
        b: [
            [f32::INFINITY; WIDTH],
            [f32::INFINITY; WIDTH],
            [f32::INFINITY; WIDTH],
            [f32::NEG_INFINITY; WIDTH],
            [f32::NEG_INFINITY; WIDTH],
            [f32::NEG_INFINITY; WIDTH],
        ],
        child: [0; WIDTH],
        count: [0; WIDTH],
        n: n as u8,
    };
    let mut interior = [(0, 0); WIDTH];
    let mut n_interior = 0;
    for (l, &c) in lanes[..n].iter().enumerate() {
        let bn = &bin[c];
        for axis in 0..3 {
            node.b[axis][l] = bn.b[0][axis];
            node.b[3 + axis][l] = bn.b[1][axis];
        }
        if bn.is_leaf() {
            node.child[l] = bn.offset;
            node.count[l] = bn.n_prims as u8;
        } else {
            node.child[l] = out.len() as u32;
            interior[n_interior] = (c, out.len());
            n_interior += 1;
            out.push(node);
        }
    }
    out[slot] = node;
    for &(c, s) in &interior[..n_interior] {
        fill(bin, c, s, out);
    }
}

/// At most how many entries the closest-hit walk of the subtree at `node`
/// holds on its stack at once, beyond those there when it got to `node`:
/// of the lanes hit it pushes all but the nearest, which it walks next,
/// and they stay while it walks down an interior one.
pub(super) fn stack_need(nodes: &[Node], node: usize) -> usize {
    let n = &nodes[node];
    let deepest = (0..usize::from(n.n))
        .filter(|&l| n.count[l] == 0)
        .map(|l| stack_need(nodes, n.child[l] as usize))
        .max()
        .unwrap_or(0);
    usize::from(n.n).saturating_sub(1) + deepest
}
