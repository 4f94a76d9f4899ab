//! The correction after impact zones. A zone moves its points rigidly, so
//! the edges that leave it end the step stretched by however far the zone
//! carried them from their neighbours (a fold caught between jaws, a cloth
//! landing on a thin bar): nothing after the zones pulls the rest of the
//! cloth along, and an edge between points of two zones, or between a zone's
//! point and one a collider carried, is stretched too. Once the zones leave
//! nothing crossing, the pass hook corrects the whole cloth, the zones' points
//! with it (the strain projection; only the points held on a path, carried
//! by an obstacle or moved out of a collider after a round, stay fixed; a
//! hook that moves nothing, as the simulator's does where that projection
//! falls short, ends the correction before it starts), and the passes of
//! impulses and the zones run again over what it moved, so the step still
//! ends on a detection of its final positions. A zone after a correction
//! sends its free points back to where the first zones left them; where
//! those zones still leave crossings, the whole correction is undone and the
//! step ends as the first zones left it. (With the zones' points fixed in the
//! correction, the edges between two of them kept what the zones left:
//! `pull_through_funnel` ended 29 frames over its limit, up to 157 %, and
//! `sleeve_elbow` one at 7 % once a scratch change elsewhere moved its
//! trajectory; with them moved, 2 and none.)

use nalgebra::Vector3;

use super::{CollisionPipeline, CollisionReport, PassHook, ResponseStage};
use crate::sim::contact::StepWindow;

/// Corrections after impact zones per step at most: each can make zones of
/// its own, corrected in turn (with one, `needles` ends a frame at 52 %).
pub(super) const ZONE_CORRECTIONS: u32 = 2;

/// Passes of impulses after a correction, before its zones take over. With
/// the step's 6, `sleeve_elbow`'s frame 69 ended at 3.8 %; with 2 the whole
/// bake stays within 1.7 %.
pub(super) const CORRECTION_PASSES: u32 = 2;

/// Rounds the zones after a correction may take before it is undone. Where
/// the correction is undone anyway (`pillars`' cloth tented on cone tips,
/// whose corrections' zones never cleared), the step's full budget made a
/// step cost up to 6 s.
const CORRECTION_ZONE_ROUNDS: u32 = 8;

impl CollisionPipeline {
    /// The impact zones after passes that left contacts, their rounds and
    /// crossings left added to `report`. Returns whether they moved anything
    /// and left nothing crossing: a correction may follow.
    pub(super) fn zones(&mut self, window: StepWindow, after_round: PassHook, report: &mut CollisionReport) -> bool {
        let allowed = match report.zone_corrections {
            0 => self.settings.zone_rounds,
            _ => CORRECTION_ZONE_ROUNDS.min(self.settings.zone_rounds),
        };
        let (rounds, left) = self.impact_zones(window, after_round, report, allowed);
        report.zone_rounds += rounds;
        report.unresolved = left;
        rounds > 0 && left == 0
    }

    /// Keeps the cloth as the step's first zones left it (to undo the
    /// corrections), hands the hook every particle held on a path (those the
    /// zones carried with an obstacle and those the hook moved after a
    /// round) as fixed, and runs it after [`ResponseStage::AfterZones`].
    /// Returns whether the hook moved anything.
    pub(super) fn correct_after_zones(&mut self, after_zones: PassHook) -> bool {
        let ws = &mut self.ws;
        if !ws.correction_kept {
            let n = self.particles.len();
            ws.zoned_end.clear();
            ws.zoned_end.extend_from_slice(&ws.end[..n]);
            ws.zoned_velocity.clear();
            ws.zoned_velocity.extend_from_slice(&ws.velocity[..n]);
            ws.correction_kept = true;
        }
        ws.frozen.clear();
        ws.frozen.extend((0..self.particles.len() as u32).filter(|&i| ws.held[i as usize].is_some()));
        self.run_hook(after_zones, ResponseStage::AfterZones)
    }

    /// Puts the cloth back where the step's first zones left it, nothing
    /// crossing: a correction's own zones left crossings.
    pub(super) fn undo_correction(&mut self, report: &mut CollisionReport) {
        let ws = &mut self.ws;
        let n = ws.zoned_end.len();
        ws.end[..n].copy_from_slice(&ws.zoned_end);
        ws.velocity[..n].copy_from_slice(&ws.zoned_velocity);
        ws.contacts.clear();
        ws.correction_kept = false;
        report.unresolved = 0;
        report.corrections_undone += 1;
    }

    /// The cloth's end positions and velocities (m, m/s) as the last
    /// resolve's first zones left them, before any correction, nothing
    /// crossing: `None` when that resolve kept no correction. A caller that measures
    /// the correction's result worse (more strain) may take these instead.
    pub fn before_last_correction(&self) -> Option<(&[Vector3<f64>], &[Vector3<f64>])> {
        let ws = &self.ws;
        ws.correction_kept.then_some((&ws.zoned_end[..], &ws.zoned_velocity[..]))
    }

    /// A round of zones after a correction: every free cloth point of a
    /// zone goes back to where the step's first zones left it. That state
    /// crossed nothing, so the zones, growing round by round, clear (at
    /// worst the whole correction goes back); moving them with the fixed
    /// points' rigid fit ran out of rounds on most of `pillars`' zone steps.
    pub(super) fn revert_zones(&mut self) {
        let ws = &mut self.ws;
        for &(_, i) in &ws.zone_members {
            let i = i as usize;
            if i < ws.zoned_end.len() && ws.inverse_mass[i] > 0.0 {
                ws.end[i] = ws.zoned_end[i];
                ws.velocity[i] = ws.zoned_velocity[i];
                ws.moved[i] = true;
            }
        }
    }
}
