//! The verdicts over a leave-one-out report and its printed table.

use super::judge::{Discriminator, VelocityCheck};
use super::{HeldOutGroup, LofoReport, MIN_RANGE_RECORDINGS};
use crate::analysis::features::FEATURE_NAMES;
use crate::eval::classifier::nearest_families_line;
use serde::Serialize;

/// The targets' verdicts over a report (docs/evaluation.md, "Leave one family out"). A group
/// whose attack share, T60 or EDT range lies wholly beyond the other groups' spread
/// ([`HeldOutGroup::beyond_others`]) is not judged: it counts as neither a pass nor a fail of
/// any target below but recognition, and is listed apart.
#[derive(Debug, Clone, Serialize)]
pub struct Summary {
    /// Held-out groups whose recordings the classifier recognises / groups.
    pub known: (usize, usize),
    /// Of those, groups whose draws are recognised ≥ 80 %.
    pub recognised: usize,
    /// Groups judged (none of the three ranges beyond the other groups' spread) / groups.
    pub judged: (usize, usize),
    /// The groups not judged, beyond the other groups' spread.
    pub beyond: Vec<String>,
    /// Judged groups with attack share, T60 and EDT all ranged / with all three inside.
    pub ranged: (usize, usize),
    /// Judged groups whose discriminator accuracy ≤ baseline + 15 points / judged groups with
    /// a discriminator.
    pub indistinct: (usize, usize),
    /// Judged groups with velocity within ±25 % / judged groups with layered objects.
    pub velocity: (usize, usize),
}

/// The features whose ranges the summary judges together.
const RANGED: [&str; 3] = ["attack_share", "t60_s", "edt_s"];

/// Counts the verdicts of `r`.
pub fn summarise(r: &LofoReport) -> Summary {
    let known: Vec<&HeldOutGroup> = r.groups.iter().filter(|f| f.classifier_knows_group()).collect();
    let rec = known
        .iter()
        .filter(|f| f.recognised as f64 >= 0.8 * f.draws as f64)
        .count();
    let (judged, beyond): (Vec<&HeldOutGroup>, Vec<&HeldOutGroup>) = r
        .groups
        .iter()
        .partition(|f| !RANGED.iter().any(|n| f.beyond_others(n)));
    let ranged: Vec<&&HeldOutGroup> = judged
        .iter()
        .filter(|f| RANGED.iter().all(|n| f.check(n).is_some()))
        .collect();
    let inside = ranged
        .iter()
        .filter(|f| RANGED.iter().all(|n| f.check(n).is_some_and(|c| c.inside)))
        .count();
    let disc: Vec<&Discriminator> = judged.iter().filter_map(|f| f.discriminator.as_ref()).collect();
    let vel: Vec<&VelocityCheck> = judged.iter().filter_map(|f| f.velocity.as_ref()).collect();
    Summary {
        known: (known.len(), r.groups.len()),
        recognised: rec,
        judged: (judged.len(), r.groups.len()),
        beyond: beyond.iter().map(|f| f.held_out.clone()).collect(),
        ranged: (ranged.len(), inside),
        indistinct: (
            disc.iter().filter(|d| d.accuracy <= d.baseline + 0.15).count(),
            disc.len(),
        ),
        velocity: (vel.iter().filter(|v| v.within).count(), vel.len()),
    }
}

fn fmt(v: f64) -> String {
    if v == f64::INFINITY {
        "inf".into()
    } else if !v.is_finite() {
        "-".into()
    } else if v != 0.0 && v.abs() < 0.01 {
        format!("{v:.2e}")
    } else if v.abs() >= 100.0 {
        format!("{v:.0}")
    } else {
        format!("{v:.3}")
    }
}

/// Writes the human-readable report.
pub fn write_table(out: &mut dyn std::io::Write, r: &LofoReport) -> std::io::Result<()> {
    let (word, words) = (r.held_out.word(), r.held_out.words());
    writeln!(
        out,
        "leave one {word} out: {} ({} recordings measured in {}, {} of the {} fitted{})",
        r.fitted,
        r.recordings,
        r.folders.join(", "),
        r.fitted_recordings,
        r.held_out.subject(),
        if r.dense { ", with dense mode fields" } else { "" }
    )?;
    for s in &r.skipped {
        writeln!(out, "  left out {}: {}", s.name, s.reason)?;
    }
    writeln!(
        out,
        "\n{:<24} {:>4} {:>9} {:>7} {:>9} {:>14} {:>14} {:>14} {:>16} {:>13}",
        format!("held-out {word}"),
        "recs",
        "rec known",
        "alpha",
        "draws rec",
        "attack share",
        "t60 s",
        "edt s",
        "discrim (base)",
        "vel rec/draws"
    )?;
    for f in &r.groups {
        let cell = |n: &str| -> String {
            let j = FEATURE_NAMES.iter().position(|x| *x == n).unwrap_or(0);
            match (&f.features[j], &f.range_skipped[j]) {
                (Some(c), _) => format!("{}{}", fmt(c.draws_median), mark(f, n, c.inside)),
                (None, _) => "SKIPPED".into(),
            }
        };
        writeln!(
            out,
            "{:<24} {:>4} {:>9} {:>7.3} {:>9} {:>14} {:>14} {:>14} {:>16} {:>13}",
            f.held_out,
            f.recordings,
            format!("{}/{}", f.recordings_recognised.0, f.recordings_recognised.1),
            f.contact_exponent,
            format!("{}/{}", f.recognised, f.draws),
            cell("attack_share"),
            cell("t60_s"),
            cell("edt_s"),
            f.discriminator.map_or_else(
                || {
                    if f.recordings < MIN_RANGE_RECORDINGS {
                        "SKIPPED".into()
                    } else {
                        "-".into()
                    }
                },
                |d| format!("{:.2} ({:.2})", d.accuracy, d.baseline)
            ),
            f.velocity.as_ref().map_or("-".into(), |v| format!(
                "{:.2}/{:.2}{}",
                v.recorded_ratio,
                v.drawn_ratio,
                if v.within { "" } else { "*" }
            )),
        )?;
    }
    writeln!(
        out,
        "(* = outside the held-out {word}'s 10-90 % range, or velocity ratio off by more than 25 %;\n \
         ! = that range lies wholly outside the other {words}' 10-90 % range: no fit from them has it,\n \
         not judged; ranges of T60 and EDT count recordings that end still ringing as lower bounds)"
    )?;
    writeln!(
        out,
        "\nper feature, draws' median [held-out {word}'s 10-90 % range] (the other {words}' range):"
    )?;
    for f in &r.groups {
        write!(out, "  {}:", f.held_out)?;
        for (j, name) in FEATURE_NAMES.iter().enumerate() {
            match (&f.features[j], &f.range_skipped[j]) {
                (Some(c), _) => write!(
                    out,
                    " {name} {} [{}..{}{}]{}{}",
                    fmt(c.draws_median),
                    fmt(c.recordings_p10),
                    fmt(c.recordings_p90),
                    censored_note(c.censored, f.recordings),
                    f.others_ranges
                        .get(j)
                        .copied()
                        .flatten()
                        .map_or(String::new(), |(lo, hi)| format!(
                            " ({}..{}{})",
                            fmt(lo),
                            fmt(hi),
                            censored_note(f.others_censored.get(j).copied().unwrap_or(0), usize::MAX)
                        )),
                    mark(f, name, c.inside)
                )?,
                (None, Some(why)) => write!(out, " {name} {why}")?,
                (None, None) => {}
            }
        }
        writeln!(out)?;
    }
    writeln!(out, "\ndraws nearest the family centres of:")?;
    for f in &r.groups {
        writeln!(
            out,
            "  {}: {}",
            f.held_out,
            nearest_families_line(&f.nearest_families)
        )?;
    }
    let s = summarise(r);
    writeln!(
        out,
        "\nsummary: {}/{} {words} recognised by the classifier themselves; of those, {} with >= 80 % of draws recognised",
        s.known.0, s.known.1, s.recognised
    )?;
    writeln!(
        out,
        "judged: {}/{} {words}{}",
        s.judged.0,
        s.judged.1,
        if s.beyond.is_empty() {
            String::new()
        } else {
            format!(
                "; beyond the other {words}' spread of attack share, T60 or EDT, not judged (!): {}",
                s.beyond.join(", ")
            )
        }
    )?;
    writeln!(
        out,
        "attack share, T60 and EDT all inside the range: {}/{} judged {words} with the three ranges",
        s.ranged.1, s.ranged.0
    )?;
    writeln!(
        out,
        "discriminator at most baseline + 15 points: {}/{} judged {words}; velocity ratio within 25 %: {}/{} judged {words}",
        s.indistinct.0, s.indistinct.1, s.velocity.0, s.velocity.1
    )?;
    Ok(())
}

/// A ranged cell's mark: `!` where the held-out range lies beyond the other groups' (not
/// judged, so neither pass nor fail), else `*` where the draws' median is outside it.
fn mark(f: &HeldOutGroup, feature: &str, inside: bool) -> &'static str {
    match (f.beyond_others(feature), inside) {
        (true, _) => "!",
        (false, true) => "",
        (false, false) => "*",
    }
}

/// `"; 3/5 censored"` for a range with censored recordings (`of` them; `usize::MAX`: the count
/// alone), empty without.
fn censored_note(censored: usize, of: usize) -> String {
    match (censored, of) {
        (0, _) => String::new(),
        (c, usize::MAX) => format!("; {c} censored"),
        (c, n) => format!("; {c}/{n} censored"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::eval::leave_out::HoldOut;
    use crate::eval::report::FeatureCheck;

    /// A held-out kit whose T60 recordings span `t60` (draws at `drawn`), beside other kits
    /// whose recordings span `others`; every other feature judged inside and within reach.
    fn kit(t60: (f64, f64), drawn: f64, others: (f64, f64)) -> HeldOutGroup {
        let features = FEATURE_NAMES
            .iter()
            .map(|&name| {
                Some(match name {
                    "t60_s" => FeatureCheck::of(name, &[drawn], &[t60.0, t60.1]),
                    _ => FeatureCheck::of(name, &[1.0], &[0.5, 2.0]),
                })
            })
            .collect();
        let others_ranges = FEATURE_NAMES
            .iter()
            .map(|&name| Some(if name == "t60_s" { others } else { (0.5, 2.0) }))
            .collect();
        HeldOutGroup {
            held_out: "kit".into(),
            recordings: 3,
            fitted_from: vec!["other".into()],
            fitted_recordings: 3,
            contact_exponent: 1.5,
            recordings_recognised: (3, 3),
            draws: 1,
            recognised: 1,
            nearest_families: Vec::new(),
            features,
            range_skipped: vec![None; FEATURE_NAMES.len()],
            others_ranges,
            others_censored: vec![0; FEATURE_NAMES.len()],
            discriminator: None,
            velocity: None,
        }
    }

    /// A held-out range that lies wholly above (or below) the other kits' is beyond them, one
    /// that meets theirs at all is not, and the summary counts the judged kits within reach.
    #[test]
    fn a_range_beyond_the_other_kits_is_marked_and_counted_apart() {
        let mut far = kit((10.0, 12.1), 3.0, (2.0, 5.0));
        let mut near = kit((2.9, 4.3), 3.2, (2.9, 4.9));
        // The kit beyond reach fails the discriminator; it must not count.
        let disc = |accuracy| Discriminator {
            recordings: 3,
            draws: 3,
            accuracy,
            baseline: 0.5,
        };
        far.discriminator = Some(disc(1.0));
        near.discriminator = Some(disc(0.5));
        let touching = kit((4.5, 6.0), 5.5, (2.0, 4.9));
        assert!(far.beyond_others("t60_s"));
        assert!(!near.beyond_others("t60_s") && !touching.beyond_others("t60_s"));
        assert!(!far.beyond_others("edt_s") && !far.beyond_others("no such feature"));
        let r = LofoReport {
            held_out: HoldOut::Kit,
            fitted: "ride cymbal".into(),
            material: "metal".into(),
            folders: Vec::new(),
            recordings: 9,
            fitted_recordings: 9,
            dense: false,
            skipped: Vec::new(),
            groups: vec![far, near, touching],
        };
        let s = summarise(&r);
        assert_eq!(s.judged, (2, 3));
        assert_eq!(s.beyond, ["kit"]);
        assert_eq!(s.ranged, (2, 2));
        assert_eq!(s.indistinct, (1, 1));
        let mut out = Vec::new();
        write_table(&mut out, &r).expect("written to memory");
        let text = String::from_utf8(out).expect("UTF-8");
        assert!(
            text.contains("t60_s 3.000 [10.210..11.890] (2.000..5.000)!"),
            "{text}"
        );
        assert!(text.contains("judged: 2/3 kits; beyond"), "{text}");
        assert!(
            text.contains("all inside the range: 2/2 judged kits with the three ranges"),
            "{text}"
        );
    }
}
