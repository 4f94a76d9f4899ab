//! Separation certificates: a pair of cloth triangles whose every feature
//! test was culled is skipped by the narrow phase while its points cannot
//! have moved far enough for one not to be.
//!
//! A narrow-phase pair of cloth triangles tests only the features whose
//! boxes meet (a vertex's box and the other triangle's, two edges' boxes),
//! and of those only the ones whose start positions lie within the
//! thickness and their relative motion of each other
//! ([`super::ccd::Outcome::Apart`]). Both culls leave a margin, and neither
//! margin changes when every point of the pair moves alike: a box spans its
//! point's start and its end in the step's frame, grown by the box growth,
//! and a feature's box is the union of its points'; the contacts depend on
//! the distances between the features over the step alone. So the pair's
//! *drift* is measured against a common motion: the least `d` such that
//! every start and framed end of its six points moved from where it was by
//! a common vector plus at most `d` in each coordinate (and the box growth
//! by at most `d`). Then
//!
//! * two feature boxes `g` apart (along the axis that parts them most,
//!   [`Box3::gap`]) stay apart while `2d < g`;
//! * features whose start positions were `c` beyond the thickness plus their
//!   relative reach stay culled while `6√3 d < c`: the start distance falls
//!   by at most `2√3 d`, the reach grows by at most `4√3 d`.
//!
//! The least of these allowances over a pair's features is its
//! *certificate*, and the pair is skipped while its drift stays below. On a
//! cloth lying on a table or hanging from it, most pairs the broad phase
//! finds are neighbours a row or two apart, never near each other's
//! features, and moving together: they are tested once, then skipped. A
//! skipped pair would have found nothing, so the contacts, and the bake,
//! are the same to the bit.
//!
//! Drifts are measured from where the points were at a reference full
//! detection (a step's first), each triangle's as its first point's move
//! (its *anchor*) and how far its other points' moves differ from it (its
//! *spread*); a pair's drift is bounded by the two spreads and the distance
//! between the anchors. A certificate found later is kept less the pair's
//! drift then. Every few full detections the certificates are taken over to
//! the points' new positions, each less its pair's drift, and those used up
//! are dropped.

use nalgebra::Vector3;
use rayon::prelude::*;

/// Certificates kept per cloth triangle (for its pairs with higher-numbered
/// triangles); a triangle with more partners than this tests the rest.
const SLOTS: usize = 12;

/// No partner in a slot.
const EMPTY: u32 = u32::MAX;

/// What a certificate must exceed the drifts by, m: far above the round-off
/// of positions a few metres from the origin, far below any thickness.
const SLACK: f64 = 1e-9;

/// How much a start-distance clearance shrinks per metre of drift: `6√3`
/// rounded up.
const CLEARANCE_PER_DRIFT: f64 = 6.0;

/// How much a box gap shrinks per metre of drift.
const GAP_PER_DRIFT: f64 = 2.0;

/// Full detections between two takeovers of the certificates to new
/// reference positions. On `drape_table` a takeover every detection, every
/// second, fourth or eighth all skip 82-83 % of the first detections' pairs,
/// and a takeover costs as much as measuring the drifts twice.
const TAKEOVER_EVERY: u32 = 4;

/// Points per parallel task when drifts are measured.
const POINTS_PER_TASK: usize = 2048;

/// How far a pair whose features' start positions were `clearance` m
/// beyond the thickness and their reach may drift before they could be
/// tested, m.
pub(super) fn drift_allowed(clearance: f64) -> f64 {
    clearance / CLEARANCE_PER_DRIFT
}

/// How far a pair whose feature boxes were `gap` m apart may drift before
/// they could meet, m.
pub(super) fn drift_allowed_by_gap(gap: f64) -> f64 {
    gap / GAP_PER_DRIFT
}

/// Where the cloth's points are for the certificates: starts, ends in the
/// step's frame, and the growth of their boxes.
#[derive(Clone, Copy, Debug)]
pub(super) struct CertifiedPoints<'a> {
    /// Start positions, m.
    pub start: &'a [Vector3<f64>],
    /// End positions, m.
    pub end: &'a [Vector3<f64>],
    /// The step's frame: ends are taken less this, m.
    pub shift: Vector3<f64>,
    /// How much every point's box is grown, m.
    pub growth: f64,
}

impl CertifiedPoints<'_> {
    /// Point `i`'s start and framed end.
    fn framed(&self, i: usize) -> [Vector3<f64>; 2] {
        [self.start[i], self.end[i] - self.shift]
    }
}

/// The certificates of one triangle: partners, and the drift each allows
/// from the epoch's start, m.
#[derive(Clone, Copy, Debug)]
struct Slots {
    partner: [u32; SLOTS],
    allowed: [f64; SLOTS],
}

impl Slots {
    const EMPTY: Slots = Slots { partner: [EMPTY; SLOTS], allowed: [0.0; SLOTS] };
}

/// The separation certificates of a pipeline's cloth triangle pairs.
#[derive(Clone, Debug, Default)]
pub(super) struct Certificates {
    /// Per cloth point: its start and framed end at the last full detection.
    reference: Vec<[Vector3<f64>; 2]>,
    /// The box growth at the last full detection, m.
    reference_growth: f64,
    /// Per cloth point: how its start and framed end moved since, m.
    moves: Vec<[Vector3<f64>; 2]>,
    /// Per cloth triangle: its anchor's (first point's) start move, m.
    anchor: Vec<Vector3<f64>>,
    /// Per cloth triangle: how far any of its points' moves differ from its
    /// anchor's, plus the box growth's change, m.
    spread: Vec<f64>,
    /// Per cloth triangle: its certified pairs with higher triangles.
    slots: Vec<Slots>,
    /// Full detections since the reference was taken.
    age: u32,
}

impl Certificates {
    /// Forgets every certificate (what the narrow phase culls changed, as
    /// when a thickness does).
    pub fn clear(&mut self) {
        *self = Certificates::default();
    }

    /// Before a full detection of the cloth's `points` and `triangles`:
    /// measures every drift and, every [`TAKEOVER_EVERY`] detections, takes
    /// the certificates over to the points' new positions, which become the
    /// reference.
    pub fn begin_full(&mut self, points: CertifiedPoints, triangles: &[[u32; 3]]) {
        if self.reference.len() != points.start.len() || self.slots.len() != triangles.len() {
            *self = Certificates {
                moves: vec![[Vector3::zeros(); 2]; points.start.len()],
                anchor: vec![Vector3::zeros(); triangles.len()],
                spread: vec![0.0; triangles.len()],
                slots: vec![Slots::EMPTY; triangles.len()],
                ..Certificates::default()
            };
        } else {
            self.measure_all(points, triangles);
            self.age += 1;
            if self.age < TAKEOVER_EVERY {
                return;
            }
            self.take_over();
        }
        self.reference.clear();
        self.reference.extend((0..points.start.len()).map(|i| points.framed(i)));
        self.reference_growth = points.growth;
    }

    /// Keeps of every certificate what the drifts just measured leave of it,
    /// and drops those they used up; the points' positions are then the
    /// reference.
    fn take_over(&mut self) {
        let (anchor, spread) = (&self.anchor, &self.spread);
        self.slots.par_iter_mut().with_min_len(POINTS_PER_TASK).enumerate().for_each(|(a, slots)| {
            for (p, allowed) in slots.partner.iter_mut().zip(&mut slots.allowed).filter(|(p, _)| **p != EMPTY) {
                *allowed -= pair_drift(anchor, spread, a, *p as usize);
                if *allowed <= SLACK {
                    *p = EMPTY;
                }
            }
        });
        self.moves.fill([Vector3::zeros(); 2]);
        self.anchor.fill(Vector3::zeros());
        self.spread.fill(0.0);
        self.age = 0;
    }

    /// Every point's move and every triangle's anchor and spread.
    fn measure_all(&mut self, points: CertifiedPoints, triangles: &[[u32; 3]]) {
        let reference = &self.reference;
        let moves = self.moves.par_iter_mut().with_min_len(POINTS_PER_TASK).enumerate();
        moves.for_each(|(i, m)| *m = moved(&reference[i], &points, i));
        let (moves, growth) = (&self.moves, (points.growth - self.reference_growth).abs());
        let spans = self.anchor.par_iter_mut().zip(self.spread.par_iter_mut()).with_min_len(POINTS_PER_TASK);
        spans.zip(triangles).for_each(|((anchor, spread), t)| (*anchor, *spread) = span(moves, *t, growth));
    }

    /// Before a detection of the points `moved` and the triangles
    /// `moved_list` holding them: measures their drifts again.
    pub fn follow_moved(
        &mut self,
        points: CertifiedPoints,
        moved: &[bool],
        triangles: &[[u32; 3]],
        moved_list: &[u32],
    ) {
        if self.reference.len() != points.start.len() {
            return;
        }
        for (i, _) in moved.iter().enumerate().filter(|&(_, &m)| m) {
            self.moves[i] = self::moved(&self.reference[i], &points, i);
        }
        let growth = (points.growth - self.reference_growth).abs();
        for &t in moved_list {
            let t = t as usize;
            (self.anchor[t], self.spread[t]) = span(&self.moves, triangles[t], growth);
        }
    }

    /// A bound on the drift of the pair of triangles `a` and `b` since the
    /// last full detection, m.
    fn drift(&self, a: usize, b: usize) -> f64 {
        pair_drift(&self.anchor, &self.spread, a, b)
    }

    /// Whether cloth triangles `a < b` are certified apart: their pair would
    /// test no feature.
    pub fn holds(&self, a: u32, b: u32) -> bool {
        let Some(slots) = self.slots.get(a as usize) else { return false };
        let Some(k) = slots.partner.iter().position(|&p| p == b) else { return false };
        slots.allowed[k] - self.drift(a as usize, b as usize) > SLACK
    }

    /// Keeps the certificate of triangles `a < b`, which may drift by
    /// `allowed` m from where they are now, if it will hold: in the slot `a`
    /// has for `b`, else in an empty one or one that no longer holds.
    pub fn record(&mut self, a: u32, b: u32, allowed: f64) {
        let Some(slots) = self.slots.get(a as usize) else { return };
        let at_reference = allowed - self.drift(a as usize, b as usize);
        if at_reference <= SLACK {
            return;
        }
        let lapsed = |k: usize| slots.allowed[k] - self.drift(a as usize, slots.partner[k] as usize) <= SLACK;
        let slot = (0..SLOTS)
            .find(|&k| slots.partner[k] == b)
            .or_else(|| (0..SLOTS).find(|&k| slots.partner[k] == EMPTY))
            .or_else(|| (0..SLOTS).find(|&k| lapsed(k)));
        if let Some(k) = slot {
            let slots = &mut self.slots[a as usize];
            (slots.partner[k], slots.allowed[k]) = (b, at_reference);
        }
    }
}

/// A bound on the drift of triangles `a` and `b` with `anchor`s and
/// `spread`s, m: with the move of `a`'s anchor as the common motion, every
/// move of `a`'s points is within `a`'s spread of it, and every move of
/// `b`'s within `b`'s spread of `b`'s anchor.
#[inline]
fn pair_drift(anchor: &[Vector3<f64>], spread: &[f64], a: usize, b: usize) -> f64 {
    spread[a] + spread[b] + (anchor[a] - anchor[b]).norm()
}

/// How point `i` of `points` moved from its `reference` start and framed end, m.
fn moved(reference: &[Vector3<f64>; 2], points: &CertifiedPoints, i: usize) -> [Vector3<f64>; 2] {
    let [start, end] = points.framed(i);
    [start - reference[0], end - reference[1]]
}

/// Triangle `t`'s anchor (its first point's start move) and spread (how far
/// its points' `moves` differ from the anchor, in any coordinate, plus the
/// box growth's change `growth`), m.
fn span(moves: &[[Vector3<f64>; 2]], t: [u32; 3], growth: f64) -> (Vector3<f64>, f64) {
    let anchor = moves[t[0] as usize][0];
    let apart = |m: &Vector3<f64>| (m - anchor).norm_squared();
    let spread = t.iter().flat_map(|&v| &moves[v as usize]).map(apart).fold(0.0, f64::max).sqrt();
    (anchor, spread + growth)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two triangles of three points each, the first's at `xa`, the
    /// second's at `xb` on the x axis.
    fn two_triangles(xa: f64, xb: f64) -> (Vec<Vector3<f64>>, Vec<[u32; 3]>) {
        let at = |x: f64| Vector3::new(x, 0.0, 0.0);
        (vec![at(xa), at(xa), at(xa), at(xb), at(xb), at(xb)], vec![[0, 1, 2], [3, 4, 5]])
    }

    /// Points still over the step at `x`.
    fn still(x: &[Vector3<f64>]) -> CertifiedPoints<'_> {
        CertifiedPoints { start: x, end: x, shift: Vector3::zeros(), growth: 0.01 }
    }

    #[test]
    fn a_move_is_taken_in_the_steps_frame() {
        let reference = [Vector3::zeros(), Vector3::new(1.0, 0.0, 0.0)];
        let (start, end) = ([Vector3::new(0.1, -0.3, 0.0)], [Vector3::new(1.5, 0.0, 0.0)]);
        let framed = CertifiedPoints { start: &start, end: &end, shift: Vector3::new(0.5, 0.0, 0.0), growth: 0.0 };
        assert_eq!(moved(&reference, &framed, 0), [Vector3::new(0.1, -0.3, 0.0), Vector3::zeros()]);
    }

    #[test]
    fn a_common_motion_is_no_drift_and_the_growths_change_is() {
        let moves = vec![[Vector3::new(0.3, 0.1, 0.0); 2]; 3];
        assert_eq!(span(&moves, [0, 1, 2], 0.0), (Vector3::new(0.3, 0.1, 0.0), 0.0));
        let (_, spread) = span(&moves, [0, 1, 2], 0.002);
        assert_eq!(spread, 0.002);
        // One end moved 0.4 along z from the others: that is the spread.
        let mut bent = moves.clone();
        bent[2][1].z = 0.4;
        assert!((span(&bent, [0, 1, 2], 0.0).1 - 0.4).abs() < 1e-15);
    }

    #[test]
    fn the_allowances_cannot_be_used_up_by_what_they_allow() {
        // Box gaps close by twice the drift; a start-distance clearance by
        // 2 (the start distance) + 4 (the reach) times it.
        assert_eq!(drift_allowed_by_gap(1.0), 0.5);
        assert!(6.0 * drift_allowed(1.0) <= 1.0);
    }

    #[test]
    fn a_certificate_holds_until_the_pair_drifts_by_what_it_allows() {
        let (mut x, triangles) = two_triangles(0.0, 1.5);
        let mut certificates = Certificates::default();
        certificates.begin_full(still(&x), &triangles);
        certificates.record(0, 1, 0.5);
        assert!(certificates.holds(0, 1));
        // Both triangles carried 10 m together: no drift.
        (x, _) = two_triangles(10.0, 11.5);
        certificates.begin_full(still(&x), &triangles);
        assert!(certificates.holds(0, 1));
        // 0.4 closer: 0.1 is left.
        (x, _) = two_triangles(10.2, 11.3);
        certificates.begin_full(still(&x), &triangles);
        assert!(certificates.holds(0, 1));
        // One point of the second triangle moves 0.1 further: nothing is left.
        x[4].x = 11.2;
        certificates.follow_moved(still(&x), &[false, false, false, false, true, false], &triangles, &[1]);
        assert!(!certificates.holds(0, 1));
    }

    #[test]
    fn a_takeover_keeps_what_the_drifts_leave_and_drops_what_they_used_up() {
        let (x, triangles) = two_triangles(0.0, 1.5);
        let mut certificates = Certificates::default();
        certificates.begin_full(still(&x), &triangles);
        certificates.record(0, 1, 0.5);
        let take_over_at = |certificates: &mut Certificates, x: &[Vector3<f64>]| {
            for _ in 0..TAKEOVER_EVERY {
                certificates.begin_full(still(x), &triangles);
            }
            assert_eq!(certificates.age, 0);
        };
        // 0.3 closer: 0.2 is left, from there.
        let (closer, _) = two_triangles(0.15, 1.35);
        take_over_at(&mut certificates, &closer);
        assert!((certificates.slots[0].allowed[0] - 0.2).abs() < 1e-12);
        // 0.2 closer still: used up, and gone when they part again.
        let (touching, _) = two_triangles(0.25, 1.25);
        take_over_at(&mut certificates, &touching);
        take_over_at(&mut certificates, &closer);
        assert!(!certificates.holds(0, 1));
    }

    #[test]
    fn a_certificate_found_after_a_move_counts_from_the_reference() {
        let (reference, triangles) = two_triangles(0.0, 1.5);
        let mut certificates = Certificates::default();
        certificates.begin_full(still(&reference), &triangles);
        // The second triangle moves 1 away, and the pair is certified for 1.5.
        let (apart, _) = two_triangles(0.0, 2.5);
        certificates.follow_moved(still(&apart), &[true; 6], &triangles, &[0, 1]);
        certificates.record(0, 1, 1.5);
        // Back at the reference, 0.5 is left.
        certificates.follow_moved(still(&reference), &[true; 6], &triangles, &[0, 1]);
        assert!(certificates.holds(0, 1));
        let (closer, _) = two_triangles(0.0, 1.0);
        certificates.follow_moved(still(&closer), &[true; 6], &triangles, &[0, 1]);
        assert!(!certificates.holds(0, 1));
    }

    #[test]
    fn a_full_triangle_replaces_certificates_that_lapsed() {
        let x = vec![Vector3::zeros(); 3];
        let triangles = vec![[0, 1, 2]; SLOTS + 2];
        let mut certificates = Certificates::default();
        certificates.begin_full(still(&x), &triangles);
        for b in 1..=SLOTS as u32 {
            certificates.record(0, b, 0.5);
        }
        let last = SLOTS as u32 + 1;
        certificates.record(0, last, 0.5);
        assert!(!certificates.holds(0, last), "no slot left");
        certificates.spread[1] = 0.6;
        certificates.record(0, last, 0.5);
        assert!(certificates.holds(0, last), "took the lapsed slot of triangle 1");
        assert!(!certificates.holds(0, 1));
    }

    #[test]
    fn clearing_forgets_every_certificate() {
        let (x, triangles) = two_triangles(0.0, 1.5);
        let mut certificates = Certificates::default();
        certificates.begin_full(still(&x), &triangles);
        certificates.record(0, 1, 0.5);
        certificates.clear();
        assert!(!certificates.holds(0, 1));
        certificates.begin_full(still(&x), &triangles);
        assert!(!certificates.holds(0, 1));
    }
}
