//! The narrow phase of one detection: each job (a cloth pair, a cloth
//! triangle against an obstacle's, or a sharp feature) tests only the
//! features its triangles own, each first culled by its box, its
//! face-diagonal slabs and a distance bound, then by continuous collision
//! detection; adjacent cloth triangles are first culled as a whole.

use super::*;

/// One triangle of a narrow-phase pair: its points and boxes.
#[derive(Clone, Copy)]
pub(super) struct Side<'a> {
    pub(super) points: [u32; 3],
    pub(super) whole: &'a Box3,
    pub(super) boxes: &'a FeatureBoxes,
    pub(super) slabs: &'a DiagonalSlabs,
}

/// Whether slabs `a` and `b` overlap, asked only when called.
fn slabs_meet<'a>(a: &'a DiagonalSlabs, b: &'a DiagonalSlabs) -> impl FnOnce() -> bool + 'a {
    move || a.overlaps(b)
}

/// Whether the slabs of edges `e1` and `e2` (points with slabs
/// `point_slabs`) overlap, asked only when called.
fn edge_slabs_meet(point_slabs: &[DiagonalSlabs], [a, b]: [u32; 2], [c, d]: [u32; 2]) -> impl FnOnce() -> bool + '_ {
    move || {
        let first = point_slabs[a as usize].union(&point_slabs[b as usize]);
        first.overlaps(&point_slabs[c as usize].union(&point_slabs[d as usize]))
    }
}

/// The points of edge `k → k + 1` of triangle `tri`.
pub(super) fn edge(tri: [u32; 3], k: usize) -> [u32; 2] {
    [tri[k], tri[(k + 1) % 3]]
}

/// Everything the narrow phase reads.
pub(super) struct Narrow<'a> {
    pub(super) pipeline_triangles: &'a [[u32; 3]],
    pub(super) ownership: &'a Ownership,
    pub(super) obstacles: &'a Obstacles,
    pub(super) particles: &'a [ParticleCollision],
    pub(super) cloth_count: usize,
    /// Per point (cloth, then obstacles): what the tests read of it.
    pub(super) point: &'a [PointState],
    pub(super) node_box: &'a [Box3],
    pub(super) triangle_box: &'a [Box3],
    /// Per point (cloth, then obstacles), its face-diagonal slabs over the step.
    pub(super) point_slabs: &'a [DiagonalSlabs],
    /// Per cloth triangle, its face-diagonal slabs over the step.
    pub(super) triangle_slabs: &'a [DiagonalSlabs],
    /// Per obstacle triangle, its box over the step.
    pub(super) obstacle_box: &'a [Box3],
    /// Per cloth triangle, the boxes of its edges and corners.
    pub(super) feature_box: &'a [FeatureBoxes],
    /// Per obstacle triangle, the boxes of its edges and corners.
    pub(super) obstacle_feature_box: &'a [FeatureBoxes],
    /// Per obstacle triangle, its face-diagonal slabs over the step.
    pub(super) obstacle_slabs: &'a [DiagonalSlabs],
    pub(super) kept: &'a [Contact],
    pub(super) detection: Detection,
}

/// What the coarse test of two adjacent cloth triangles reads: the cloth's
/// triangles with their feature boxes, boxes and slabs, and its points'
/// slabs.
pub(super) struct AdjacentCull<'a> {
    pub(super) triangles: &'a [[u32; 3]],
    pub(super) feature_box: &'a [FeatureBoxes],
    pub(super) triangle_box: &'a [Box3],
    pub(super) point_slabs: &'a [DiagonalSlabs],
    pub(super) triangle_slabs: &'a [DiagonalSlabs],
}

impl AdjacentCull<'_> {
    /// Whether any feature pair of cloth triangles `t1` and `t2`, which
    /// meet as `sharing` says, may pass its box and slab culls, by a test
    /// every such pair would pass:
    ///
    /// * sharing one corner, one feature of a feature pair is made of
    ///   points the other triangle lacks (the corner is in one feature at
    ///   most): the edge opposite the corner, which must meet the other
    ///   triangle;
    /// * sharing an edge, the feature pairs are each corner off it against
    ///   the other triangle, and the two edge pairs that join those corners
    ///   to different ends of the shared edge.
    pub(super) fn may_meet(&self, t1: usize, t2: usize, sharing: Sharing) -> bool {
        let k = |byte: u8| usize::from(byte);
        match sharing {
            Sharing::Corner { first_edge, second_edge } => {
                self.edge_meets_triangle((t1, k(first_edge)), t2) || self.edge_meets_triangle((t2, k(second_edge)), t1)
            }
            Sharing::Edge { first_corner, second_corner, second_to_far, second_to_near } => {
                let corner = k(first_corner);
                self.corner_meets_triangle(t1, corner, t2)
                    || self.corner_meets_triangle(t2, k(second_corner), t1)
                    || self.edges_meet((t1, corner), (t2, k(second_to_far)))
                    || self.edges_meet((t1, (corner + 2) % 3), (t2, k(second_to_near)))
            }
        }
    }

    /// The face-diagonal slabs of edge `k` of cloth triangle `t`.
    fn edge_slabs(&self, (t, k): (usize, usize)) -> DiagonalSlabs {
        let [a, b] = edge(self.triangles[t], k).map(|v| v as usize);
        self.point_slabs[a].union(&self.point_slabs[b])
    }

    /// Whether corner `k` of cloth triangle `t` meets cloth triangle `other`
    /// by box and by slabs.
    fn corner_meets_triangle(&self, t: usize, k: usize, other: usize) -> bool {
        let point = self.triangles[t][k] as usize;
        self.feature_box[t].corners[k].overlaps(&self.triangle_box[other])
            && self.point_slabs[point].overlaps(&self.triangle_slabs[other])
    }

    /// Whether edge `k` of cloth triangle `t` meets cloth triangle `other`
    /// by box and by slabs.
    fn edge_meets_triangle(&self, (t, k): (usize, usize), other: usize) -> bool {
        self.feature_box[t].edges[k].overlaps(&self.triangle_box[other])
            && self.edge_slabs((t, k)).overlaps(&self.triangle_slabs[other])
    }

    /// Whether edge `k1` of cloth triangle `t1` and edge `k2` of cloth
    /// triangle `t2` meet by box and by slabs.
    fn edges_meet(&self, (t1, k1): (usize, usize), (t2, k2): (usize, usize)) -> bool {
        self.feature_box[t1].edges[k1].overlaps(&self.feature_box[t2].edges[k2])
            && self.edge_slabs((t1, k1)).overlaps(&self.edge_slabs((t2, k2)))
    }
}

/// Merges into the workspace's sorted `pairs` the pairs of `adjacent`
/// cloth `triangles` ([`crate::sim::collision::adjacent`]) that pass the coarse test of
/// [`AdjacentCull::may_meet`] (their jobs cull the features themselves):
/// among all the listed triangles, or with `moved` the pairs holding a
/// moved triangle.
pub(super) fn add_adjacent_pairs(
    (adjacent, triangles): (&AdjacentTriangles, &[[u32; 3]]),
    moved: bool,
    ws: &mut Workspace,
) {
    let Workspace { feature_box, triangle_box, point_slabs, triangle_slabs, moved_list, moved_triangle, .. } = ws;
    let cull = AdjacentCull { triangles, feature_box, triangle_box, point_slabs, triangle_slabs };
    let (scan, moved_triangle) = match moved {
        true => (&moved_list[..], Some(&moved_triangle[..])),
        false => (adjacent.members(), None),
    };
    let found = &mut ws.adjacent_pairs;
    parallel_queries(scan, &mut ws.query_chunks, found, |a, _, pairs| {
        for (&h, &sharing) in adjacent.of(a).iter().zip(adjacent.sharing_of(a)) {
            let once = moved_triangle.map_or(a < h, |moved| !moved[h as usize] || a < h);
            if once && cull.may_meet(a as usize, h as usize, sharing) {
                pairs.push((a.min(h), a.max(h)));
            }
        }
    });
    if !found.is_empty() {
        if moved {
            ws.pair_sorter.sort(found);
        }
        std::mem::swap(&mut ws.pairs, &mut ws.broad_pairs);
        merge_sorted(ws.broad_pairs.iter().copied(), found, &mut ws.pairs);
    }
}

/// Elementary tests of a detection that passed the box test.
#[derive(Clone, Copy, Debug, Default)]
pub(in crate::sim::collision) struct TestCount {
    /// Run, each feature tested from its owner only.
    pub(super) run: u64,
    /// That would have run with every feature tested from each triangle
    /// holding it (see [`crate::sim::collision::features`]).
    pub(super) without_ownership: u64,
}

impl TestCount {
    /// One test run, which `sharing` triangle pairs would have run without
    /// ownership.
    fn add(&mut self, sharing: u32) {
        self.run += 1;
        self.without_ownership += u64::from(sharing);
    }
}

impl Narrow<'_> {
    fn path(&self, i: u32) -> Path {
        self.point[i as usize].path
    }

    /// The distance a contact between features of `nodes` must keep, m.
    fn thickness(&self, nodes: &[u32]) -> f64 {
        nodes.iter().map(|&i| self.point[i as usize].thickness).fold(0.0, f64::max)
    }

    /// Whether a hit is what this detection looks for.
    fn wanted(&self, hit: &Hit) -> bool {
        hit.crossing || self.detection != Detection::Crossings
    }

    /// The obstacle's friction if it names one, else the mean of the cloth
    /// particles' fabrics.
    fn friction(&self, nodes: &[u32], body: Option<u32>) -> f64 {
        let (sum, count) = nodes
            .iter()
            .filter_map(|&i| self.particles.get(i as usize))
            .fold((0.0, 0), |(s, n), p| (s + p.friction, n + 1));
        body.and_then(|b| self.obstacles.bodies[b as usize].friction).unwrap_or(sum / count.max(1) as f64)
    }

    /// The obstacle body of a point, if it is an obstacle vertex.
    fn body(&self, node: u32) -> Option<u32> {
        (node as usize).checked_sub(self.cloth_count).map(|o| self.obstacles.vertex_collider[o])
    }

    /// Whether point `i` moves by prescription (a pinned particle or an
    /// obstacle vertex): contacts among such points only can be neither
    /// answered nor caused by the solver, so they are not tested.
    fn kinematic(&self, i: u32) -> bool {
        self.point[i as usize].kinematic
    }

    /// Vertex `p` (box `p_box`) against triangle `tri` (point indices, box
    /// `tri_box`): culled by box, by `slabs_meet` (false when their slabs are
    /// apart) and by the start distance, else tested and counted as
    /// `sharing` tests without ownership.
    fn vertex_triangle(
        &self,
        (p, p_box): (u32, &Box3),
        (tri, tri_box): ([u32; 3], &Box3),
        slabs_meet: impl FnOnce() -> bool,
        sharing: u32,
        found: &mut Vec<Contact>,
        count: &mut TestCount,
    ) {
        if tri.contains(&p) || !p_box.overlaps(tri_box) || !slabs_meet() {
            return;
        }
        if self.kinematic(p) && tri.iter().all(|&v| self.kinematic(v)) {
            return;
        }
        count.add(sharing);
        let thickness = self.thickness(&[p, tri[0], tri[1], tri[2]]);
        let touching = self.detection.reach(thickness);
        let (point, [pa, pb, pc]) = (self.path(p), tri.map(|v| self.path(v)));
        let reach = relative_reach(&[point], &[pa, pb, pc]);
        let hit = vertex_triangle_within(&point, &pa, &pb, &pc, touching, reach);
        if let Some(hit) = hit.filter(|h| self.wanted(h)) {
            let nodes = [p, tri[0], tri[1], tri[2]];
            let body = nodes.iter().find_map(|&i| self.body(i));
            let friction = self.friction(&nodes, body);
            found.push(Contact { kind: ContactKind::VertexTriangle, nodes, hit, thickness, friction });
        }
    }

    /// Edge `e1` (box `box1`) against edge `e2` (box `box2`): culled by box,
    /// by `slabs_meet` and by distance, else tested and counted as `sharing`
    /// tests without ownership.
    fn edge_edge(
        &self,
        (e1, box1): ([u32; 2], &Box3),
        (e2, box2): ([u32; 2], &Box3),
        slabs_meet: impl FnOnce() -> bool,
        sharing: u32,
        found: &mut Vec<Contact>,
        count: &mut TestCount,
    ) {
        if e1.iter().any(|v| e2.contains(v)) || !box1.overlaps(box2) || !slabs_meet() {
            return;
        }
        let nodes = [e1[0], e1[1], e2[0], e2[1]];
        if nodes.iter().all(|&v| self.kinematic(v)) {
            return;
        }
        count.add(sharing);
        let thickness = self.thickness(&nodes);
        let touching = self.detection.reach(thickness);
        let [pa, pb, pc, pd] = nodes.map(|v| self.path(v));
        let hit = edge_edge_within(&pa, &pb, &pc, &pd, touching, relative_reach(&[pa, pb], &[pc, pd]));
        if let Some(hit) = hit.filter(|h| self.wanted(h)) {
            let body = nodes.iter().find_map(|&i| self.body(i));
            let friction = self.friction(&nodes, body);
            found.push(Contact { kind: ContactKind::EdgeEdge, nodes, hit, thickness, friction });
        }
    }

    /// Cloth triangle `t` as one side of a pair.
    fn cloth_side(&self, t: usize) -> Side<'_> {
        let (points, whole, boxes) = (self.pipeline_triangles[t], &self.triangle_box[t], &self.feature_box[t]);
        Side { points, whole, boxes, slabs: &self.triangle_slabs[t] }
    }

    /// The box of the edge between points `e`.
    fn edge_box_of(&self, e: [u32; 2]) -> Box3 {
        self.node_box[e[0] as usize].union(&self.node_box[e[1] as usize])
    }

    /// Runs one job, appending contacts and counting the feature pairs that
    /// pass the box test, with representative triangles and without.
    pub(super) fn run(&self, job: Job, found: &mut Vec<Contact>, count: &mut TestCount) {
        let cloth = |t: u32| self.pipeline_triangles[t as usize];
        let offset = self.cloth_count as u32;
        match job {
            Job::Cloth(t1, t2) | Job::Mesh(t1, t2) => {
                let (t1, t2) = (t1 as usize, t2 as usize);
                let first = self.cloth_side(t1);
                let (second, owner2) = if matches!(job, Job::Mesh(..)) {
                    let points = self.obstacles.triangles[t2].map(|v| v + offset);
                    let (whole, boxes) = (&self.obstacle_box[t2], &self.obstacle_feature_box[t2]);
                    (Side { points, whole, boxes, slabs: &self.obstacle_slabs[t2] }, &self.obstacles.ownership)
                } else {
                    (self.cloth_side(t2), self.ownership)
                };
                if !first.slabs.overlaps(second.slabs) {
                    return;
                }
                // Feature pairs are told apart by their slabs too.
                let point_slabs = self.point_slabs;
                let vertex_slabs = |p: u32, triangle| slabs_meet(&point_slabs[p as usize], triangle);
                for k in self.ownership.vertices(t1) {
                    let corner = (first.points[k], &first.boxes.corners[k]);
                    let sharing = self.ownership.vertex_sharing(t1, k);
                    let slabs = vertex_slabs(first.points[k], second.slabs);
                    self.vertex_triangle(corner, (second.points, second.whole), slabs, sharing, found, count);
                }
                for k in owner2.vertices(t2) {
                    let corner = (second.points[k], &second.boxes.corners[k]);
                    let sharing = owner2.vertex_sharing(t2, k);
                    let slabs = vertex_slabs(second.points[k], first.slabs);
                    self.vertex_triangle(corner, (first.points, first.whole), slabs, sharing, found, count);
                }
                for k1 in self.ownership.edges(t1) {
                    let e1 = (edge(first.points, k1), &first.boxes.edges[k1]);
                    for k2 in owner2.edges(t2) {
                        let e2 = (edge(second.points, k2), &second.boxes.edges[k2]);
                        let sharing = self.ownership.edge_sharing(t1, k1) * owner2.edge_sharing(t2, k2);
                        self.edge_edge(e1, e2, edge_slabs_meet(point_slabs, e1.0, e2.0), sharing, found, count);
                    }
                }
            }
            Job::Vertex(t, v) => {
                let (v, tri_box) = (v + offset, &self.triangle_box[t as usize]);
                let slabs = slabs_meet(&self.point_slabs[v as usize], &self.triangle_slabs[t as usize]);
                self.vertex_triangle((v, &self.node_box[v as usize]), (cloth(t), tri_box), slabs, 1, found, count);
            }
            Job::Again(k) => {
                let contact = &self.kept[k as usize];
                let [a, b, c, d] = contact.nodes;
                match contact.kind {
                    ContactKind::VertexTriangle => {
                        let tri_box = self.node_box[b as usize].union(&self.node_box[c as usize]);
                        let tri_box = tri_box.union(&self.node_box[d as usize]);
                        let vertex = (a, &self.node_box[a as usize]);
                        self.vertex_triangle(vertex, ([b, c, d], &tri_box), || true, 1, found, count);
                    }
                    ContactKind::EdgeEdge => {
                        let (box1, box2) = (self.edge_box_of([a, b]), self.edge_box_of([c, d]));
                        self.edge_edge(([a, b], &box1), ([c, d], &box2), || true, 1, found, count);
                    }
                }
            }
            Job::Edge(t, e) => {
                let obstacle = self.obstacles.feature_edges[e as usize].map(|v| v + offset);
                let obstacle_box = self.edge_box_of(obstacle);
                let edges = &self.feature_box[t as usize].edges;
                for k in self.ownership.edges(t as usize) {
                    let sharing = self.ownership.edge_sharing(t as usize, k);
                    let e = (edge(cloth(t), k), &edges[k]);
                    let slabs = edge_slabs_meet(self.point_slabs, e.0, obstacle);
                    self.edge_edge(e, (obstacle, &obstacle_box), slabs, sharing, found, count);
                }
            }
        }
    }
}
