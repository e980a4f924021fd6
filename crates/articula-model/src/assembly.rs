//! The binary assembly tree of the divide-and-conquer algorithm (docs/design.md#assembly-tree).
//!
//! Vertices are the model's bodies plus the ground; edges are the bodies' joints (joint `i`
//! is body `i`'s joint to its parent). Each internal node joins two subassemblies at one joint,
//! its *principal joint*; its *handles* are the joints by which it connects to the rest. The tree
//! is built by cutting, recursively, the joint that best balances the two sides (ties go to the
//! cut whose sides have fewer handles), so a chain of n links gets depth ⌈log2(n + 1)⌉ and two
//! handles per node at most.
//!
//! A body (or the ground) with more than [`GATHER_ABOVE`] children is a *gather* node instead:
//! each child's whole subtree is built first (by the same cuts, one handle: its joint to the
//! hub), then one node absorbs them all into the hub, so no node carries a handle per child
//! (docs/design.md#assembly-tree).
//!
//! [`AssemblyTree::build_clustered`] builds DCA's own tree, in which chosen small subtrees are
//! *leaf clusters*: absorbed into their parent body's leaf, which solves them in inertia form
//! as ABA does ([`NodeKind::Cluster`]), so that the joins see only the coarse tree
//! (docs/algorithms.md#leaf-clusters). [`Model::assembly`](crate::Model) has none.

use crate::Model;

/// A body (or the ground) with more than this many children becomes a [`NodeKind::Gather`]
/// node. Below it, balanced cuts give the hub's nodes at most this many handles; above it their
/// `nh²` blocks would grow as the cube of the child count. (Every bundled model and every robot
/// of example-robot-data has at most a handful of children per body, so none has a gather node.)
pub const GATHER_ABOVE: usize = 16;

/// What a node of the assembly tree is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NodeKind {
    /// The ground (the world, or a fixed base's welded root): zero inverse inertia.
    Ground,
    /// A rigid body of the model.
    Body(usize),
    /// Two subassemblies joined at the joint of body `joint`.
    Join {
        /// The principal joint: the joint of this body (its parent is on the `parent_side`).
        joint: usize,
        /// The node holding the principal joint's parent body ("A" in docs/design.md#assembly-tree).
        parent_side: usize,
        /// The node holding the principal joint's child body ("B" in docs/design.md#assembly-tree).
        child_side: usize,
    },
    /// A hub with more than [`GATHER_ABOVE`] children and all its descendants: the hub's body
    /// (`None`: the ground) and the subassemblies of its children's subtrees, each with one
    /// handle (its joint to the hub), at `AssemblyTree::gathered[first..first + count]` in the
    /// order of the hub's children. Its one handle is the hub's own joint (none for the ground).
    Gather {
        /// The hub's body, `None` for the ground.
        body: Option<usize>,
        /// Where its children's nodes start in [`AssemblyTree::gathered`].
        first: usize,
        /// How many children.
        count: usize,
    },
    /// A body (`None`: the ground) with the subtrees of some of its children absorbed: those
    /// bodies are at `AssemblyTree::clustered[first..first + count]`, in index order (parents
    /// first), and their joints are no handles. Its handles are the body's own joint and its
    /// other children's, as a [`NodeKind::Body`]'s (the ground's: its other root bodies').
    Cluster {
        /// The body that absorbs them, `None` for the ground.
        body: Option<usize>,
        /// Where its absorbed bodies start in [`AssemblyTree::clustered`].
        first: usize,
        /// How many absorbed bodies.
        count: usize,
    },
}

/// A node of the assembly tree.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct AssemblyNode {
    /// Leaf or join.
    pub kind: NodeKind,
    /// The joints connecting this subassembly to the rest, sorted (joint `i` = body `i`'s joint).
    pub handles: Vec<usize>,
    /// The parent node, `None` at the root.
    pub parent: Option<usize>,
    /// Distance from the root (the root has depth 0).
    pub depth: usize,
    /// Number of bodies (the ground included) in the subassembly.
    pub size: usize,
}

/// The assembly tree, nodes in post-order: children before parents, the root last. A bottom-up
/// pass is a forward loop over `nodes`; a top-down pass is a backward loop.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct AssemblyTree {
    /// The nodes in post-order.
    pub nodes: Vec<AssemblyNode>,
    /// For each body, its leaf node.
    pub body_leaf: Vec<usize>,
    /// For each joint (= body), the node whose principal joint it is.
    pub joint_node: Vec<usize>,
    /// The ground's leaf node (or the gather node whose hub it is).
    pub ground_leaf: usize,
    /// The children of the gather nodes (see [`NodeKind::Gather`]), flat.
    pub gathered: Vec<usize>,
    /// The bodies the cluster nodes absorb (see [`NodeKind::Cluster`]), flat.
    pub clustered: Vec<usize>,
}

impl AssemblyTree {
    /// The root node (the last one).
    pub fn root(&self) -> usize {
        self.nodes.len() - 1
    }

    /// Height of the tree: the largest node depth.
    pub fn depth(&self) -> usize {
        self.nodes.iter().map(|n| n.depth).max().unwrap_or(0)
    }

    /// The subassemblies a gather node absorbs (empty for any other node).
    pub fn gather_children(&self, n: usize) -> &[usize] {
        match self.nodes[n].kind {
            NodeKind::Gather { first, count, .. } => &self.gathered[first..first + count],
            _ => &[],
        }
    }

    /// The bodies a cluster node absorbs, parents first (empty for any other node).
    pub fn cluster_bodies(&self, n: usize) -> &[usize] {
        match self.nodes[n].kind {
            NodeKind::Cluster { first, count, .. } => &self.clustered[first..first + count],
            _ => &[],
        }
    }

    /// Whether some node is a [`NodeKind::Gather`].
    pub fn has_gather(&self) -> bool {
        !self.gathered.is_empty()
    }

    /// The largest handle count of any node.
    pub fn max_handles(&self) -> usize {
        self.nodes
            .iter()
            .map(|n| n.handles.len())
            .max()
            .unwrap_or(0)
    }

    /// Builds the tree by balanced cuts.
    pub fn build(model: &Model) -> AssemblyTree {
        Self::build_clustered(model, &[])
    }

    /// Builds the tree by balanced cuts with leaf clusters: each body `i` with `absorbed[i]`
    /// belongs, with its whole subtree, to its parent's leaf (or the ground's, for a root
    /// body), which becomes a [`NodeKind::Cluster`]. An empty `absorbed` (or one of all
    /// `false`) gives [`AssemblyTree::build`]'s tree. A hub with more than [`GATHER_ABOVE`]
    /// children must absorb none of them.
    pub fn build_clustered(model: &Model, absorbed: &[bool]) -> AssemblyTree {
        let coarse = Coarse::new(model, absorbed);
        let drafts = Cutter::new(coarse).cut();
        let mut tree = renumber(drafts, model.bodies.len());
        tree.link_nodes();
        tree
    }

    /// Sets every node's parent and depth, and the leaf of each body and the node of each
    /// joint, from the root down.
    fn link_nodes(&mut self) {
        let tree = self;
        for i in (0..tree.nodes.len()).rev() {
            let depth = tree.nodes[i].depth;
            match tree.nodes[i].kind {
                NodeKind::Join {
                    joint,
                    parent_side,
                    child_side,
                } => {
                    tree.joint_node[joint] = i;
                    for c in [parent_side, child_side] {
                        tree.nodes[c].parent = Some(i);
                        tree.nodes[c].depth = depth + 1;
                    }
                }
                NodeKind::Gather { body, first, count } => {
                    match body {
                        Some(b) => tree.body_leaf[b] = i,
                        None => tree.ground_leaf = i,
                    }
                    for k in first..first + count {
                        let c = tree.gathered[k];
                        tree.nodes[c].parent = Some(i);
                        tree.nodes[c].depth = depth + 1;
                        // The child's one handle, its joint to the hub, is absorbed here.
                        let joint = tree.nodes[c].handles[0];
                        tree.joint_node[joint] = i;
                    }
                }
                NodeKind::Cluster { body, first, count } => {
                    match body {
                        Some(b) => tree.body_leaf[b] = i,
                        None => tree.ground_leaf = i,
                    }
                    for &c in &tree.clustered[first..first + count] {
                        tree.body_leaf[c] = i;
                        tree.joint_node[c] = i;
                    }
                }
                NodeKind::Body(b) => tree.body_leaf[b] = i,
                NodeKind::Ground => tree.ground_leaf = i,
            }
        }
    }

    /// The tree as an indented outline, one node a line, for people and snapshot tests.
    pub fn outline(&self, model: &Model) -> String {
        let mut out = String::new();
        let mut stack = vec![(self.root(), 0usize)];
        while let Some((i, indent)) = stack.pop() {
            let node = &self.nodes[i];
            let handles: Vec<String> = node
                .handles
                .iter()
                .map(|&j| model.bodies[j].joint_name())
                .collect();
            let line = match node.kind {
                NodeKind::Ground => "ground".to_string(),
                NodeKind::Body(b) => format!("body {}", model.bodies[b].name),
                NodeKind::Join {
                    joint,
                    parent_side,
                    child_side,
                } => {
                    stack.push((child_side, indent + 1));
                    stack.push((parent_side, indent + 1));
                    format!("join {}", model.bodies[joint].joint_name())
                }
                NodeKind::Gather { body, first, count } => {
                    for &c in self.gathered[first..first + count].iter().rev() {
                        stack.push((c, indent + 1));
                    }
                    match body {
                        Some(b) => format!("gather body {}", model.bodies[b].name),
                        None => "gather ground".to_string(),
                    }
                }
                NodeKind::Cluster { body, count, .. } => {
                    let at = body.map_or("ground".to_string(), |b| {
                        format!("body {}", model.bodies[b].name)
                    });
                    format!("cluster {at} (+{count} bodies)")
                }
            };
            out.push_str(&"  ".repeat(indent));
            out.push_str(&line);
            if !handles.is_empty() {
                out.push_str(&format!("  [handles: {}]", handles.join(", ")));
            }
            out.push('\n');
        }
        out
    }
}

/// Where each node's per-handle data lives in flat arrays, and how a join's handles come from
/// its two children — the bookkeeping every pass over the tree shares.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct HandleLayout {
    /// Per node: offset of its handles in flat per-handle arrays.
    pub hoff: Vec<usize>,
    /// Per node: offset of its `nh × nh` handle-pair blocks (row-major) in flat arrays.
    pub boff: Vec<usize>,
    /// Total number of handles (all nodes).
    pub handles: usize,
    /// Total number of handle-pair blocks (all nodes).
    pub blocks: usize,
    /// Per join node: index of the principal joint among the parent side's handles (0 otherwise).
    pub ja: Vec<usize>,
    /// Per join node: index of the principal joint among the child side's handles (0 otherwise).
    pub jb: Vec<usize>,
    /// Per handle of a join node (flat, `hoff`): `(true, i)` when it is handle `i` of the parent
    /// side, `(false, i)` when it is handle `i` of the child side.
    pub from: Vec<(bool, usize)>,
}

impl AssemblyTree {
    /// The flat-array layout of the tree's handles.
    pub fn handle_layout(&self) -> HandleLayout {
        let nn = self.nodes.len();
        let mut l = HandleLayout {
            hoff: Vec::with_capacity(nn),
            boff: Vec::with_capacity(nn),
            ja: vec![0; nn],
            jb: vec![0; nn],
            ..HandleLayout::default()
        };
        for node in &self.nodes {
            l.hoff.push(l.handles);
            l.boff.push(l.blocks);
            l.handles += node.handles.len();
            l.blocks += node.handles.len() * node.handles.len();
        }
        l.from = vec![(true, 0); l.handles];
        for (i, node) in self.nodes.iter().enumerate() {
            if let NodeKind::Join {
                joint,
                parent_side,
                child_side,
            } = node.kind
            {
                let (ha, hb) = (
                    &self.nodes[parent_side].handles,
                    &self.nodes[child_side].handles,
                );
                let pos = |hs: &[usize], j: usize| hs.iter().position(|&x| x == j);
                l.ja[i] = pos(ha, joint).expect("principal joint is a handle of A");
                l.jb[i] = pos(hb, joint).expect("principal joint is a handle of B");
                for (k, &hc) in node.handles.iter().enumerate() {
                    l.from[l.hoff[i] + k] = match pos(ha, hc) {
                        Some(p) => (true, p),
                        None => (
                            false,
                            pos(hb, hc).expect("handle of C is a handle of A or B"),
                        ),
                    };
                }
            }
        }
        l
    }
}

/// A node of the tree while [`AssemblyTree::build_clustered`] cuts it, before renumbering.
struct Draft {
    kind: NodeKind,
    handles: Vec<usize>,
    size: usize,
    /// A join's two sides (A, B) or a gather's subassemblies.
    children: Vec<usize>,
    /// A cluster's absorbed bodies.
    cluster: Vec<usize>,
}

impl Draft {
    fn empty() -> Draft {
        Draft {
            kind: NodeKind::Ground,
            handles: Vec::new(),
            size: 0,
            children: Vec::new(),
            cluster: Vec::new(),
        }
    }
}

/// The coarse tree that [`AssemblyTree::build_clustered`] cuts: one vertex per body not
/// absorbed into a leaf cluster, plus the ground (vertex `n`).
struct Coarse<'a> {
    model: &'a Model,
    ground: usize,
    /// Each vertex's children in the coarse tree.
    children: Vec<Vec<usize>>,
    /// Per vertex, the bodies of the subtrees it absorbs (leaf clusters), in index order;
    /// an absorbed body is no vertex of the coarse tree.
    cluster: Vec<Vec<usize>>,
    /// Hubs, the gather nodes' vertices: in its parent's component a hub stands for its
    /// whole subtree (its weight), and its children are no handles there.
    hub: Vec<bool>,
    /// Bodies each vertex stands for.
    weight: Vec<usize>,
}

impl<'a> Coarse<'a> {
    fn new(model: &'a Model, absorbed: &[bool]) -> Coarse<'a> {
        let n = model.bodies.len();
        let absorbed = |v: usize| absorbed.get(v).copied().unwrap_or(false);
        let ground = n;
        let mut children: Vec<Vec<usize>> = vec![Vec::new(); n + 1];
        let mut cluster: Vec<Vec<usize>> = vec![Vec::new(); n + 1];
        let mut owner = vec![usize::MAX; n];
        for v in 0..n {
            let p = model.bodies[v].parent.unwrap_or(ground);
            if absorbed(v) || (p != ground && owner[p] != usize::MAX) {
                let o = if p != ground && owner[p] != usize::MAX {
                    owner[p]
                } else {
                    p
                };
                owner[v] = o;
                cluster[o].push(v);
            } else {
                children[p].push(v);
            }
        }
        let hub: Vec<bool> = children.iter().map(|c| c.len() > GATHER_ABOVE).collect();
        let mut weight: Vec<usize> = cluster.iter().map(|c| 1 + c.len()).collect();
        if hub.contains(&true) {
            let mut full = weight.clone();
            for v in (0..n).rev() {
                if owner[v] == usize::MAX {
                    full[model.bodies[v].parent.unwrap_or(ground)] += full[v];
                }
            }
            for v in 0..=n {
                if hub[v] {
                    weight[v] = full[v];
                }
            }
        }
        Coarse {
            model,
            ground,
            children,
            cluster,
            hub,
            weight,
        }
    }

    /// Vertex parent (ground for the root bodies); the ground has none.
    fn parent(&self, v: usize) -> Option<usize> {
        if v == self.ground {
            None
        } else {
            Some(self.model.bodies[v].parent.unwrap_or(self.ground))
        }
    }

    /// The component of `root`'s subtree, down to the hubs (included): `root` first, then
    /// the bodies in stored order (parents first), so a forward loop visits parents before
    /// children. Without hubs, the ground's is the ground then every body.
    fn component(&self, root: usize) -> Vec<usize> {
        let mut out = vec![root];
        let mut i = 0;
        while i < out.len() {
            let v = out[i];
            i += 1;
            if !self.hub[v] {
                out.extend_from_slice(&self.children[v]);
            }
        }
        out[1..].sort_unstable();
        out
    }
}

/// The balanced cuts of a [`Coarse`] tree, component by component.
struct Cutter<'a> {
    coarse: Coarse<'a>,
    drafts: Vec<Draft>,
    /// Work items: (component vertices, index of its draft node).
    work: Vec<(Vec<usize>, usize)>,
    /// Scratch indexed by vertex: membership stamp, subtree size, handles inside subtree.
    stamp: Vec<usize>,
    sub: Vec<usize>,
    hsub: Vec<usize>,
}

impl<'a> Cutter<'a> {
    fn new(coarse: Coarse<'a>) -> Cutter<'a> {
        let n = coarse.ground;
        let mut drafts = Vec::with_capacity(2 * n + 1);
        drafts.push(Draft::empty());
        let work = vec![(coarse.component(coarse.ground), 0usize)];
        Cutter {
            coarse,
            drafts,
            work,
            stamp: vec![usize::MAX; n + 1],
            sub: vec![0usize; n + 1],
            hsub: vec![0usize; n + 1],
        }
    }

    /// Cuts until every component is a leaf; the draft nodes, the root first.
    fn cut(mut self) -> Vec<Draft> {
        while let Some((comp, id)) = self.work.pop() {
            for &v in &comp {
                self.stamp[v] = id;
            }
            self.drafts[id].handles = self.handles(&comp, id);
            let m: usize = comp.iter().map(|&v| self.coarse.weight[v]).sum();
            self.drafts[id].size = m;
            if comp.len() == 1 {
                self.leaf(comp[0], id);
                continue;
            }
            let cut = self.best_cut(&comp, id, m);
            self.split(comp, id, cut, m);
        }
        self.drafts
    }

    /// Handles of component `id`: the top vertex's own joint if its parent is outside, plus
    /// joints to children outside (a hub's are inside its gather node). Resets `sub` and
    /// counts each vertex's own outside children in `hsub`.
    fn handles(&mut self, comp: &[usize], id: usize) -> Vec<usize> {
        let c = &self.coarse;
        let mut handles = Vec::new();
        for &v in comp {
            self.hsub[v] = 0;
            self.sub[v] = c.weight[v];
            if let Some(p) = c.parent(v) {
                if self.stamp[p] != id {
                    handles.push(v);
                }
            }
            if c.hub[v] {
                continue;
            }
            for &ch in &c.children[v] {
                if self.stamp[ch] != id {
                    handles.push(ch);
                    self.hsub[v] += 1;
                }
            }
        }
        handles.sort_unstable();
        handles
    }

    /// A one-vertex component: a gather node (a hub: each child's subtree a subassembly of
    /// its own), a cluster, a body or the ground.
    fn leaf(&mut self, v: usize, id: usize) {
        let ground = self.coarse.ground;
        if self.coarse.hub[v] {
            let first = self.drafts.len();
            for &c in &self.coarse.children[v] {
                self.work
                    .push((self.coarse.component(c), self.drafts.len()));
                self.drafts.push(Draft::empty());
            }
            self.drafts[id].kind = NodeKind::Gather {
                body: (v != ground).then_some(v),
                first: 0,
                count: self.coarse.children[v].len(),
            };
            self.drafts[id].children = (first..self.drafts.len()).collect();
        } else if !self.coarse.cluster[v].is_empty() {
            self.drafts[id].kind = NodeKind::Cluster {
                body: (v != ground).then_some(v),
                first: 0,
                count: self.coarse.cluster[v].len(),
            };
            self.drafts[id].cluster = std::mem::take(&mut self.coarse.cluster[v]);
        } else {
            self.drafts[id].kind = if v == ground {
                NodeKind::Ground
            } else {
                NodeKind::Body(v)
            };
        }
    }

    /// The inner joint of component `id` (weight `m`) whose cut balances the two sides best,
    /// then their handle counts; a floating base's 6-DOF joint for the root component.
    fn best_cut(&mut self, comp: &[usize], id: usize, m: usize) -> usize {
        let c = &self.coarse;
        // Subtree sizes within the component, children before parents.
        for &v in comp.iter().rev() {
            if let Some(p) = c.parent(v) {
                if self.stamp[p] == id {
                    self.sub[p] += self.sub[v];
                    self.hsub[p] += self.hsub[v];
                }
            }
        }
        let total_h = self.drafts[id].handles.len();
        let mut best: Option<((usize, usize), usize)> = None;
        for &v in comp {
            let Some(p) = c.parent(v) else { continue };
            if self.stamp[p] != id {
                continue;
            }
            let balance = self.sub[v].max(m - self.sub[v]);
            let h_child = self.hsub[v] + 1;
            let h_parent = total_h - self.hsub[v] + 1;
            let score = (balance, h_child.max(h_parent));
            if best.is_none_or(|(s, _)| score < s) {
                best = Some((score, v));
            }
        }
        let (_, cut) =
            best.expect("a connected component of two or more vertices has an inner joint");
        // A floating base's 6-DOF joint is the root cut: the free body is then one subtree
        // of the root, so an adaptive hybrid body can keep it moving as one rigid body
        // (articula-adaptive) while every internal joint is frozen.
        if id == 0 && c.model.floating_base && c.ground > 0 {
            0
        } else {
            cut
        }
    }

    /// Splits component `id` at joint `cut` into a join node of its two sides.
    fn split(&mut self, comp: Vec<usize>, id: usize, cut: usize, m: usize) {
        // The child side is the subtree of `cut` inside the component.
        let mut in_child = Vec::with_capacity(self.sub[cut]);
        let mut parent_side = Vec::with_capacity(m - self.sub[cut]);
        // Mark the child side by walking the component in order (parents first).
        let child_mark = usize::MAX - 1;
        for &v in &comp {
            let inside = v == cut
                || self
                    .coarse
                    .parent(v)
                    .is_some_and(|p| self.stamp[p] == child_mark);
            if inside {
                in_child.push(v);
                self.stamp[v] = child_mark;
            } else {
                parent_side.push(v);
            }
        }
        for &v in &comp {
            self.stamp[v] = id;
        }
        let a = self.drafts.len();
        let b = a + 1;
        self.drafts.push(Draft::empty());
        self.drafts.push(Draft::empty());
        self.drafts[id].kind = NodeKind::Join {
            joint: cut,
            parent_side: a,
            child_side: b,
        };
        self.drafts[id].children = vec![a, b];
        self.work.push((parent_side, a));
        self.work.push((in_child, b));
    }
}

/// The draft nodes renumbered in post-order (iterative), child references fixed; parents
/// and depths are left to [`AssemblyTree::link_nodes`].
fn renumber(mut tmp: Vec<Draft>, n: usize) -> AssemblyTree {
    let mut new_index = vec![usize::MAX; tmp.len()];
    let mut post = Vec::with_capacity(tmp.len());
    let mut stack = vec![(0usize, false)];
    while let Some((t, expanded)) = stack.pop() {
        if !expanded && !tmp[t].children.is_empty() {
            stack.push((t, true));
            for &c in tmp[t].children.iter().rev() {
                stack.push((c, false));
            }
        } else {
            new_index[t] = post.len();
            post.push(t);
        }
    }
    let mut tree = AssemblyTree {
        nodes: Vec::with_capacity(post.len()),
        body_leaf: vec![0; n],
        joint_node: vec![0; n],
        ground_leaf: 0,
        gathered: Vec::new(),
        clustered: Vec::new(),
    };
    for &t in &post {
        let kind = match tmp[t].kind {
            NodeKind::Join {
                joint,
                parent_side,
                child_side,
            } => NodeKind::Join {
                joint,
                parent_side: new_index[parent_side],
                child_side: new_index[child_side],
            },
            NodeKind::Gather { body, count, .. } => {
                let first = tree.gathered.len();
                tree.gathered
                    .extend(tmp[t].children.iter().map(|&c| new_index[c]));
                NodeKind::Gather { body, first, count }
            }
            NodeKind::Cluster { body, count, .. } => {
                let first = tree.clustered.len();
                tree.clustered.extend_from_slice(&tmp[t].cluster);
                NodeKind::Cluster { body, first, count }
            }
            k => k,
        };
        tree.nodes.push(AssemblyNode {
            kind,
            handles: std::mem::take(&mut tmp[t].handles),
            parent: None,
            depth: 0,
            size: tmp[t].size,
        });
    }
    tree
}

#[cfg(test)]
mod tests {
    use super::{AssemblyTree, NodeKind};
    use crate::{LoadOptions, Model};

    /// A torso on a revolute joint with three limbs: two arms of two links and a tail of four.
    fn torso() -> Model {
        let link = |n: &str| {
            format!("<link name=\"{n}\"><inertial><mass value=\"1\"/><inertia ixx=\"0.01\" iyy=\"0.01\" izz=\"0.01\" ixy=\"0\" ixz=\"0\" iyz=\"0\"/></inertial></link>")
        };
        let joint = |n: &str, p: &str, c: &str| {
            format!("<joint name=\"{n}\" type=\"revolute\"><parent link=\"{p}\"/><child link=\"{c}\"/><origin xyz=\"0 0 0.1\"/><axis xyz=\"0 1 0\"/><limit lower=\"-1\" upper=\"1\" effort=\"1\" velocity=\"1\"/></joint>")
        };
        let mut s = String::from("<robot name=\"t\">") + &link("base") + &link("torso");
        s += &joint("jt", "base", "torso");
        for (limb, len) in [("l", 2), ("r", 2), ("tail", 4)] {
            let mut parent = "torso".to_string();
            for k in 0..len {
                let name = format!("{limb}{k}");
                s += &link(&name);
                s += &joint(&format!("j{name}"), &parent, &name);
                parent = name;
            }
        }
        Model::from_urdf_str(&(s + "</robot>"), &LoadOptions::default()).unwrap()
    }

    /// Absorbing the two arms into the torso: one cluster node holds the torso and the arms'
    /// four bodies, their joints are handles of no node, the tail is cut by joins as before,
    /// every body is in exactly one leaf, and the root holds every body and the ground.
    #[test]
    fn clusters_absorb_subtrees_into_their_parents_leaf() {
        let model = torso();
        let n = model.bodies.len();
        let name = |i: usize| model.bodies[i].name.as_str();
        let absorbed: Vec<bool> = (0..n).map(|i| name(i).starts_with(['l', 'r'])).collect();
        let tree = AssemblyTree::build_clustered(&model, &absorbed);
        let clusters: Vec<usize> = (0..tree.nodes.len())
            .filter(|&x| matches!(tree.nodes[x].kind, NodeKind::Cluster { .. }))
            .collect();
        assert_eq!(clusters.len(), 1);
        let c = clusters[0];
        let torso = (0..n).find(|&i| name(i) == "torso").unwrap();
        assert_eq!(
            tree.nodes[c].kind,
            NodeKind::Cluster {
                body: Some(torso),
                first: 0,
                count: 4
            }
        );
        let mut inside: Vec<&str> = tree.cluster_bodies(c).iter().map(|&i| name(i)).collect();
        inside.sort_unstable();
        assert_eq!(inside, ["l0", "l1", "r0", "r1"]);
        // Its handles: the torso's joint and the tail's first joint.
        let tail0 = (0..n).find(|&i| name(i) == "tail0").unwrap();
        assert_eq!(
            tree.nodes[c].handles,
            vec![torso.min(tail0), torso.max(tail0)]
        );
        for (i, &a) in absorbed.iter().enumerate() {
            if a {
                assert_eq!(tree.body_leaf[i], c);
                assert_eq!(tree.joint_node[i], c);
                assert!(tree.nodes.iter().all(|nd| !nd.handles.contains(&i)));
            } else if i != torso {
                assert_eq!(tree.nodes[tree.body_leaf[i]].kind, NodeKind::Body(i));
            }
        }
        assert_eq!(tree.nodes[tree.root()].size, n + 1);
        assert_eq!(tree.nodes.len(), 2 * (n - 4) + 1);
        // Without clusters: the model's own tree.
        assert_eq!(AssemblyTree::build_clustered(&model, &[]), model.assembly);
        assert!(tree
            .outline(&model)
            .contains("cluster body torso (+4 bodies)"));
    }
}
