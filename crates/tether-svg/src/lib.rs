//! Small helpers for self-contained SVG and HTML pictures, shared by the simulator's
//! pictures and the reports (docs/design.md, *Crates and tiers*): text escaping, round
//! scale-bar lengths, grid spacing, places for a label beside a point, and the colours
//! of people. Nothing here knows a world, a scenario or a recording.
//!
//! A crate of its own so that the report of a real recording draws its scale bar and
//! escapes its text without the simulator.

/// Colours for the people: the target in red, others from a colour-blind-safe set.
pub fn person_color(index: usize, is_target: bool) -> &'static str {
    const OTHERS: [&str; 6] = [
        "#0072b2", "#009e73", "#e69f00", "#cc79a7", "#56b4e9", "#f0e442",
    ];
    if is_target {
        "#d62728"
    } else {
        OTHERS[index % OTHERS.len()]
    }
}

/// The grid's spacing for a world `span_m` across: 1 m, or the smallest of 2, 5, 10,
/// 20, 50 m... that draws at most 60 lines.
pub fn grid_step_m(span_m: f64) -> f64 {
    let mut step = 1.0;
    for k in 0..40 {
        if !(span_m.is_finite() && span_m / step > 60.0) {
            break;
        }
        step = [2.0, 5.0, 10.0][k % 3] * 10f64.powi((k / 3) as i32);
    }
    step
}

/// The longest "round" length (1, 2 or 5 times a power of ten) of at most `max_m`: a
/// scale bar's length (1 for a non-positive or non-finite `max_m`).
pub fn round_length_m(max_m: f64) -> f64 {
    if !(max_m.is_finite() && max_m > 0.0) {
        return 1.0;
    }
    let mag = 10f64.powf(max_m.log10().floor());
    let norm = max_m / mag;
    // A hair of tolerance: 0.3 / 0.1 is 2.9999999999999996.
    let nice = if norm >= 5.0 - 1e-9 {
        5.0
    } else if norm >= 2.0 - 1e-9 {
        2.0
    } else {
        1.0
    };
    nice * mag
}

/// Where a label `w` x `h` px may go beside pixel `(u, v)`, best first, as its left end
/// and baseline: `gap` px off the point to the right, below, left and above, then
/// `lift` px farther up or down.
pub fn label_spots(
    (u, v): (f64, f64),
    (w, h): (f64, f64),
    gap: f64,
    lift: f64,
) -> [(f64, f64); 10] {
    [
        (u + gap, v - gap),
        (u + gap, v + gap + h),
        (u - gap - w, v - gap),
        (u - gap - w, v + gap + h),
        (u - w / 2.0, v - gap - lift),
        (u - w / 2.0, v + gap + h + lift),
        (u + gap, v - gap - h - lift),
        (u + gap, v + gap + 2.0 * h + lift),
        (u - gap - w, v - gap - h - lift),
        (u - gap - w, v + gap + 2.0 * h + lift),
    ]
}

/// A length for a label: "20 cm", "2 m", "500 m".
pub fn length_text(m: f64) -> String {
    if m < 1.0 {
        let cm = format!("{:.1}", 100.0 * m);
        format!("{} cm", cm.trim_end_matches('0').trim_end_matches('.'))
    } else {
        let v = format!("{m:.2}");
        format!("{} m", v.trim_end_matches('0').trim_end_matches('.'))
    }
}

/// Escapes text for SVG and HTML.
pub fn xml_escape(text: &str) -> String {
    text.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_lengths() {
        assert_eq!(round_length_m(3.2), 2.0);
        assert_eq!(round_length_m(0.3), 0.2);
        assert_eq!(round_length_m(10.3), 10.0);
        assert_eq!(round_length_m(0.0), 1.0);
        assert_eq!(length_text(0.2), "20 cm");
        assert_eq!(length_text(0.005), "0.5 cm");
        assert_eq!(length_text(10.0), "10 m");
    }

    #[test]
    fn the_grid_step_keeps_a_large_world_to_a_few_lines() {
        assert_eq!(grid_step_m(30.0), 1.0);
        assert_eq!(grid_step_m(60.0), 1.0);
        assert_eq!(grid_step_m(61.0), 2.0);
        assert_eq!(grid_step_m(250.0), 5.0);
        assert_eq!(grid_step_m(20_000.0), 500.0);
        assert_eq!(grid_step_m(f64::INFINITY), 1.0);
        for span in [1.0, 77.0, 999.0, 1e4, 1e7] {
            assert!(span / grid_step_m(span) <= 60.0, "{span}");
        }
    }
}
