//! The banked slot layout of DCA's buffers for the parallel driver (`parallel_dca.rs`): the
//! subtrees solved side by side get disjoint slots and join scratch.

use articula_model::AssemblyTree;

/// Levels of the assembly tree split across tasks: up to `2^SPLIT_DEPTH` subtrees, each solved
/// serially by one task (the grain), so that up to 8 threads have work and the work-stealing
/// pool evens out unequal subtrees.
pub(crate) const SPLIT_DEPTH: usize = 3;

/// The banked slot layout of `tree` (no gather node; `side[n]`: 0 for a join's parent side,
/// 1 for its child side): per node its slot index (its handles' slots are at `index · max_h`),
/// the index count, per node its join scratch bank, and the bank count.
///
/// The top nodes (depth below [`SPLIT_DEPTH`]) each get a slot and a scratch bank of their
/// own, numbered in reverse post-order (a parent before its children, so a join's slot lies
/// below its children's, as `dca::c_blocks` needs); below them, subtree `t` (rooted at depth
/// [`SPLIT_DEPTH`]) has slots `top + t · (2 D + 2) + 2 δ + side` (D the tree's depth) and
/// scratch bank `top + t`.
pub(crate) fn banked_slots(
    tree: &AssemblyTree,
    side: &[usize],
) -> (Vec<usize>, usize, Vec<usize>, usize) {
    let nn = tree.nodes.len();
    let per = 2 * tree.depth() + 2;
    let (mut si, mut ys) = (vec![0; nn], vec![0; nn]);
    let mut top = 0;
    for n in (0..nn).rev() {
        if tree.nodes[n].depth < SPLIT_DEPTH {
            si[n] = top;
            ys[n] = top;
            top += 1;
        }
    }
    // Reverse post-order: a node after its parent, whose bank is then known.
    let mut bank = vec![0; nn];
    let mut banks = 0;
    for n in (0..nn).rev() {
        let nd = &tree.nodes[n];
        if nd.depth < SPLIT_DEPTH {
            continue;
        }
        bank[n] = if nd.depth == SPLIT_DEPTH {
            banks += 1;
            banks - 1
        } else {
            bank[nd.parent.expect("a node below the root has a parent")]
        };
        si[n] = top + bank[n] * per + 2 * nd.depth + side[n];
        ys[n] = top + bank[n];
    }
    (si, top + banks * per, ys, top + banks)
}
