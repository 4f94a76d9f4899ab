//! The viewport's statistics overlay: what the last simulated frame cost and
//! how good it is.

use crate::bake::FrameRecord;

/// The overlay's first line, in plain words: the frame and its time, how
/// fast the simulation runs (frames of animation per second of wall time,
/// while it runs), the intersections and the largest stretch of the cloth,
/// with what of it the pins force where they are further apart than the
/// cloth between them may reach.
pub fn summary_line(record: &FrameRecord, fps: f64, live_rate: Option<f64>) -> String {
    let mut parts = vec![format!("frame {} · {:.2} s", record.frame, record.frame as f64 / fps)];
    if let Some(rate) = live_rate {
        parts.push(format!("simulating {rate:.0} frames/s"));
    }
    let count = record.intersections.pairs();
    parts.push(match count {
        1 => "1 intersection".to_owned(),
        n => format!("{n} intersections"),
    });
    if record.frame > 0 {
        let mut stretch = format!("stretch {:.2} %", record.max_free_strain.min(record.max_strain) * 100.0);
        if let Some(unreachable) = &record.limits_unreachable {
            stretch += &format!(" (pins out of reach force {:.2} points)", unreachable.forced_strain * 100.0);
        }
        parts.push(stretch);
    }
    parts.join(" · ")
}

/// The overlay's lines for the frame `record` (frame 0, the initial state,
/// has only the checker's count).
pub fn overlay_lines(record: &FrameRecord) -> Vec<String> {
    let mut lines = Vec::new();
    let total_ms = record.timings.total().as_secs_f64() * 1e3;
    if record.frame > 0 && record.steps > 0 {
        let steps_per_s = if total_ms > 0.0 { f64::from(record.steps) * 1e3 / total_ms } else { 0.0 };
        lines.push(format!(
            "frame {}  {:.1} ms  ({} steps of up to {:.1} ms, {:.1} ms/step, {:.0} steps/s)",
            record.frame,
            total_ms,
            record.steps,
            record.longest_step_s * 1e3,
            total_ms / f64::from(record.steps),
            steps_per_s
        ));
        let mut stages: Vec<_> = record.timings.stages().into_iter().filter(|(_, d)| !d.is_zero()).collect();
        stages.sort_by_key(|&(_, d)| std::cmp::Reverse(d));
        let shown: Vec<String> =
            stages.iter().take(4).map(|(name, d)| format!("{name} {:.1}", d.as_secs_f64() * 1e3)).collect();
        lines.push(format!("stages ms: {}", shown.join(", ")));
        lines.push(format!(
            "CG {:.1} it/step  contacts {} particle, {} triangle",
            f64::from(record.cg_iterations) / f64::from(record.steps),
            record.contacts,
            record.triangle_contacts
        ));
        let mut strain = format!("strain max {:.2} %", record.max_strain * 100.0);
        if record.max_free_strain < record.max_strain {
            strain += &format!(" ({:.2} % not between pins)", record.max_free_strain * 100.0);
        }
        lines.push(format!("{strain}  mean {:.2} %", record.mean_strain * 100.0));
        if let Some(unreachable) = &record.limits_unreachable {
            let beyond = record.free_strain_beyond_pins() * 100.0;
            lines.push(format!("{unreachable}; the strain beyond what they force: {beyond:.2} %"));
        }
        lines.push(format!("cloth moving {:.1} mm/s on average", record.mean_speed_m_per_s * 1e3));
        if record.rollbacks > 0 {
            let causes = record.rollback_causes.phrases().join(", ");
            lines.push(format!("{} steps rolled back and halved ({causes})", record.rollbacks));
        }
        if record.long_steps_rejected > 0 {
            lines.push(format!("{} long steps too far off, taken again shorter", record.long_steps_rejected));
        }
    } else {
        lines.push(format!("frame {} (initial state)", record.frame));
    }
    let i = &record.intersections;
    lines.push(format!(
        "intersections {} (cloth-cloth {}, cloth-body {}), vertices inside {}",
        i.pairs(),
        i.cloth_pairs,
        i.collider_pairs,
        i.penetrating_vertices
    ));
    lines
}

#[cfg(test)]
mod tests {
    use std::time::Duration;

    use super::*;
    use crate::metrics::intersections::Intersections;
    use crate::sim::pin_reach::Unreachable;

    #[test]
    fn overlay_reports_time_per_step_strain_and_the_checkers_count() {
        let mut record =
            FrameRecord { frame: 7, steps: 4, cg_iterations: 40, max_strain: 0.0123, ..Default::default() };
        record.longest_step_s = 1.0 / 120.0;
        record.timings.solve = Duration::from_millis(30);
        record.timings.narrow = Duration::from_millis(10);
        record.intersections = Intersections { cloth_pairs: 2, collider_pairs: 1, penetrating_vertices: 0 };
        let lines = overlay_lines(&record);
        assert!(lines[0].contains("40.0 ms") && lines[0].contains("10.0 ms/step") && lines[0].contains("100 steps/s"));
        assert!(lines[0].contains("4 steps of up to 8.3 ms"), "{}", lines[0]);
        assert!(lines[1].starts_with("stages ms: solve 30.0, narrow 10.0"), "{}", lines[1]);
        assert!(lines[2].contains("10.0 it/step"));
        assert!(lines[3].contains("1.23 %"));
        assert!(lines.last().unwrap().starts_with("intersections 3 (cloth-cloth 2, cloth-body 1)"));
        record.long_steps_rejected = 1;
        assert!(overlay_lines(&record).contains(&"1 long steps too far off, taken again shorter".to_owned()));
    }

    #[test]
    fn the_first_line_speaks_plainly() {
        let record = FrameRecord { frame: 45, max_strain: 0.137, max_free_strain: 0.0102, ..Default::default() };
        let line = summary_line(&record, 30.0, Some(28.4));
        assert_eq!(line, "frame 45 · 1.50 s · simulating 28 frames/s · 0 intersections · stretch 1.02 %");
        let first = FrameRecord::default();
        assert_eq!(summary_line(&first, 30.0, None), "frame 0 · 0.00 s · 0 intersections");
    }

    /// How fast the cloth still moves, so a designer sees when the drape
    /// has come to rest.
    #[test]
    fn overlay_shows_how_fast_the_cloth_moves() {
        let record = FrameRecord { frame: 90, steps: 2, mean_speed_m_per_s: 0.0110, ..Default::default() };
        assert_eq!(overlay_lines(&record)[4], "cloth moving 11.0 mm/s on average");
    }

    /// Where the largest strain is an edge between two pins (a waistband
    /// glued to stretching skin), the cloth's own largest strain is shown too.
    #[test]
    fn overlay_shows_the_strain_off_the_pins_when_the_pins_stretch_more() {
        let record =
            FrameRecord { frame: 7, steps: 2, max_strain: 0.137, max_free_strain: 0.0102, ..Default::default() };
        assert!(overlay_lines(&record)[3].starts_with("strain max 13.70 % (1.02 % not between pins)"));
        let record = FrameRecord { max_free_strain: 0.137, ..record };
        assert!(overlay_lines(&record)[3].starts_with("strain max 13.70 %  mean"));
    }

    /// Pins out of reach explain only the strain they force: the rest is
    /// shown beside them (a tube wound round itself between pins 1 mm out of
    /// reach is not explained by them).
    #[test]
    fn overlay_shows_the_strain_beyond_what_unreachable_pins_force() {
        let unreachable = Unreachable { pins: [0, 4032], excess_m: 0.0012, forced_strain: 0.0012 };
        let record = FrameRecord {
            frame: 35,
            steps: 2,
            max_strain: 6.01,
            max_free_strain: 6.01,
            limits_unreachable: Some(unreachable),
            ..Default::default()
        };
        let first = summary_line(&record, 30.0, None);
        assert_eq!(
            first,
            "frame 35 · 1.17 s · 0 intersections · stretch 601.00 % (pins out of reach force 0.12 points)"
        );
        let line = &overlay_lines(&record)[4];
        assert!(line.starts_with("limits unreachable: pins 0 and 4032 are 0.0012 m further apart"), "{line}");
        assert!(
            line.ends_with(
                "(at least 0.12 points of strain over the limit); the strain beyond what they force: 600.88 %"
            ),
            "{line}"
        );
    }
}
