//! Assembling a preset from fitted recordings: one part (mode distribution, transient, damping
//! law) per family and for the whole material, one exemplar component per recording, the
//! contact stiffness, provenance, and the JSON `tactus fit` writes.

use super::{density, distribution};
use crate::analysis::signal::{energy_db, Mode};
use crate::fit::pool::damping;
use crate::fit::recording::{bands, DenseTransients, FileResult};
use crate::preset::{
    DampingModel, DenseField, Family, ModeDistribution, ModeModel, Origin, Preset, Provenance,
    TransientDistribution, FORMAT_VERSION,
};
use std::path::Path;

/// Modes, transient and damping law fitted from one group of recordings.
struct Part {
    modes: ModeDistribution,
    transient: TransientDistribution,
    damping: Option<DampingModel>,
    /// Per recording: its poolable modes (merged, strike noise left out, contact divided out).
    files: Vec<Vec<Mode>>,
    /// Per recording: its transient bands (level dB with the contact divided out, decay dB/s).
    transients: Vec<Vec<Option<(f64, f64)>>>,
    /// Per recording: the same with its dense partials played, swelling and flat
    /// ([`FileResult::dense_transient`]).
    dense_transients: Vec<Option<DenseTransients>>,
}

/// Fits one family (or the pooled material) from `results`. Levels are pre-compensated for
/// the default strike's contact ([`distribution::ContactCompensation`]); decays are stored
/// relative to the fitted damping law where one could be fitted.
fn fit_part(
    results: &[&FileResult],
    count: usize,
    contact: &distribution::ContactCompensation,
    what: &str,
) -> anyhow::Result<Part> {
    if let Some(r) = results.iter().find(|r| {
        r.modes
            .iter()
            .any(|m| !(m.freq_hz.is_finite() && m.level_db.is_finite() && m.decay_db_per_s.is_finite()))
    }) {
        anyhow::bail!(
            "{what}: {}: a mode's level, decay or frequency is not finite",
            r.name
        );
    }
    // Each recording's ringing modes (`ringing_modes`), the default strike's contact divided out.
    let files: Vec<Vec<Mode>> = results
        .iter()
        .map(|r| {
            let mut m = r.ringing.clone();
            for x in &mut m {
                x.level_db += contact.boost_db(x.freq_hz);
            }
            m
        })
        .collect();
    let fewest = results
        .iter()
        .zip(&files)
        .min_by_key(|(_, m)| m.len())
        .map(|(r, m)| (r.name.clone(), m.len()));
    let count = fewest.as_ref().map_or(0, |f| f.1).min(count);
    if count < 2 {
        let (name, n) = fewest.unwrap_or_default();
        anyhow::bail!("{what}: every recording must yield at least 2 modes, {name} yields {n}");
    }
    let (omega, c): (Vec<f64>, Vec<f64>) = files
        .iter()
        .flatten()
        .map(|m| {
            (
                std::f64::consts::TAU * m.freq_hz,
                m.decay_db_per_s / crate::preset::c_to_db_per_s(1.0),
            )
        })
        .unzip();
    let damping = damping::fit_emg(&omega, &c, true)
        .map(|d| DampingModel {
            alpha1: d.alpha1.clamp(0.0, 1.0e5),
            alpha2: d.alpha2.clamp(0.0, 1.0),
            alpha3: d.alpha3.clamp(0.5, 1.5),
            sigma: d.sigma.clamp(0.0, 1.0e5),
            eta: d.eta.clamp(0.0, 1.0e5),
        })
        .filter(|d| {
            [d.alpha1, d.alpha2, d.alpha3, d.sigma, d.eta]
                .iter()
                .all(|v| v.is_finite())
                && d.decay_db_per_s(1000.0) > 0.0
        });
    let dist = distribution::fit_modes(&files, count, damping.as_ref())
        .map_err(|e| anyhow::anyhow!("{what}: {e}"))?;
    // The same per-file level shift the modes got (strongest mode → its normalised mean).
    let top_mean = dist.gaussian.mean[..count]
        .iter()
        .cloned()
        .fold(f64::NEG_INFINITY, f64::max);
    let shift: Vec<f64> = files
        .iter()
        .map(|m| {
            let top = m.iter().map(|x| x.level_db).fold(f64::NEG_INFINITY, f64::max);
            top_mean - top
        })
        .collect();
    let mut centres = Vec::new();
    crate::engine::dsp::scales::erb_centres(
        bands::BANDS,
        bands::BAND_LOW_HZ,
        bands::BAND_HIGH_HZ,
        &mut centres,
    );
    let compensate = |bands: &[Option<(f64, f64)>]| -> Vec<Option<(f64, f64)>> {
        bands
            .iter()
            .zip(&centres)
            .map(|(b, &f)| b.map(|(l, d)| (l + contact.boost_db(f), d)))
            .collect()
    };
    let tr: Vec<Vec<Option<(f64, f64)>>> = results.iter().map(|r| compensate(&r.ringing_transient)).collect();
    let dense_tr = results
        .iter()
        .map(|r| {
            r.dense_transient.as_ref().map(|d| DenseTransients {
                swelling: compensate(&d.swelling),
                flat: compensate(&d.flat),
            })
        })
        .collect();
    let transient = distribution::fit_transient_distribution(&tr, &shift);
    Ok(Part {
        modes: dist,
        transient,
        damping,
        files,
        transients: tr,
        dense_transients: dense_tr,
    })
}

/// The exemplar mixture of one family (docs/presets.md, "Pooling into a preset"): one component per
/// recording, centred on that recording's own modes and transient, with the family's damping
/// law and a kernel whose size spread follows Silverman's rule over the family's recordings.
/// Why not one Gaussian per frequency rank: rank k of one recording is not the same mode as
/// rank k of another (a bar's fundamental pooled with another bar's strike component), so the
/// rank Gaussian draws objects whose slow and fast modes are mixed across recordings.
fn exemplar_families(
    family: &str,
    members: &[&FileResult],
    part: &Part,
    count: usize,
    contact: Option<&distribution::ContactCompensation>,
) -> anyhow::Result<Vec<Family>> {
    let kernel = distribution::ExemplarKernel {
        size_sd_octaves: distribution::size_bandwidth_octaves(&part.files, count),
    };
    members
        .iter()
        .zip(&part.files)
        .zip(part.transients.iter().zip(&part.dense_transients))
        .map(|((r, modes), (tr, dense_tr))| {
            let file = Path::new(&r.name)
                .file_name()
                .map_or_else(|| r.name.clone(), |n| n.to_string_lossy().into_owned());
            let (dist, shift) = distribution::fit_exemplar(modes, count, part.damping.as_ref(), kernel)
                .map_err(|e| anyhow::anyhow!("family '{family}': {file}: {e}"))?;
            // One component as fitted with its dense partials swelling or starting at full
            // level: its field, and the strike noise fitted beside those partials
            // (`FileResult::dense_transient`); without a field, the noise beside the ringing
            // modes alone.
            let component = |build_ups: bool| {
                let dense = contact
                    .and_then(|c| density::fit_dense(&strongest(modes, count), &r.dense, c, build_ups));
                let tr = match (&dense, dense_tr) {
                    (Some(_), Some(d)) if build_ups => &d.swelling,
                    (Some(_), Some(d)) => &d.flat,
                    _ => tr,
                };
                Family {
                    name: format!("{family}: {file}"),
                    weight: 1.0,
                    modes: ModeModel::Distribution(dist.clone()),
                    transient: Some(distribution::fit_transient_distribution(
                        std::slice::from_ref(tr),
                        &[shift],
                    )),
                    damping: part.damping,
                    dense,
                    size_class: None,
                }
            };
            let mut fam = component(true);
            if let Some(c) = contact {
                // The version without build-ups only matters where the field has some.
                let flat = fam
                    .dense
                    .as_ref()
                    .is_some_and(DenseField::builds_up)
                    .then(|| component(false));
                density::calibrate_family(&mut fam, flat, &r.dense, c);
            }
            Ok(fam)
        })
        .collect()
}

/// The `count` strongest of `modes` by energy: an exemplar component's modes
/// ([`distribution::fit_exemplar`]).
fn strongest(modes: &[Mode], count: usize) -> Vec<Mode> {
    let mut m = modes.to_vec();
    m.sort_by(|a, b| energy_db(b).total_cmp(&energy_db(a)));
    m.truncate(count);
    m
}

/// The preset's contact stiffness: the class default `class_n_per_m`, raised (×1.25 steps, at
/// most ×10⁴) until the default strike's compensation boost
/// ([`distribution::ContactCompensation::boost_db`]) is below its cap at the highest frequency
/// among each recording's `count` strongest modes. Why: the recordings' own strikes excited
/// those modes, and where the default contact cuts a mode by more than the capped boost
/// restores, every default hit loses it (a wood block's energy lies at 3–6 kHz, above what the
/// wood default's contact passes).
fn contact_stiffness_for(class_n_per_m: f64, results: &[FileResult], count: usize, exponent: f64) -> f64 {
    let f_hi = results
        .iter()
        .flat_map(|r| r.ringing.iter().take(count).map(|x| x.freq_hz))
        .fold(0.0, f64::max);
    let under_cap = |k: f64| {
        distribution::ContactCompensation::default_strike(k, exponent).boost_db(f_hi)
            < distribution::MAX_CONTACT_BOOST_DB - 1.0
    };
    let mut k = class_n_per_m;
    while !under_cap(k) && k < 1.0e4 * class_n_per_m {
        k *= 1.25;
    }
    k
}

/// Mixture weight of each recording (in `results` order), family-balanced: every family
/// weighs the same, every object of a family the same within it, and every recording (velocity
/// layer) of an object the same within that. Why: a material is the families it is made of,
/// not the families that happen to have the most recordings (ten marimba bars beside one
/// clave would otherwise make "wood" a marimba), and an object recorded at six strengths is
/// still one object. `objects` (one id per recording) defaults to one object per recording,
/// `families` to one family. The weights sum to 1.
pub fn balanced_weights(families: Option<&[String]>, objects: Option<&[String]>, n: usize) -> Vec<f64> {
    use std::collections::{BTreeMap, BTreeSet};
    let fam = |i: usize| families.and_then(|f| f.get(i)).map_or("", String::as_str);
    let obj = |i: usize| -> String {
        objects
            .and_then(|o| o.get(i))
            .cloned()
            .unwrap_or_else(|| format!("#{i}"))
    };
    let mut objects_of: BTreeMap<&str, BTreeSet<String>> = BTreeMap::new();
    let mut layers_of: BTreeMap<(&str, String), usize> = BTreeMap::new();
    for i in 0..n {
        objects_of.entry(fam(i)).or_default().insert(obj(i));
        *layers_of.entry((fam(i), obj(i))).or_default() += 1;
    }
    let n_fam = objects_of.len() as f64;
    (0..n)
        .map(|i| 1.0 / (n_fam * objects_of[fam(i)].len() as f64 * layers_of[&(fam(i), obj(i))] as f64))
        .collect()
}

/// Which family and which object each recording (in `results` order) belongs to; `None`: one
/// family, one object per recording.
#[derive(Debug, Clone, Copy, Default)]
pub struct Groups<'a> {
    /// The family of each recording.
    pub families: Option<&'a [String]>,
    /// The object of each recording (velocity layers of one object share it).
    pub objects: Option<&'a [String]>,
}

/// The preset `pooling` makes of `results` grouped by `groups`, for a striker contact of
/// exponent `contact_exponent` (the levels' compensation follows the default strike, which
/// depends on it): with several families a mixture of one distribution per family,
/// family-balanced ([`balanced_weights`]), beside the material pooled over all of them; a dense
/// mode field fitted to each dense recording when `pooling.dense` ([`density`]).
pub fn assemble(
    pooling: &super::Pooling,
    results: &[FileResult],
    groups: &Groups,
    contact_exponent: f64,
) -> anyhow::Result<Preset> {
    let (material, name, count, dense) = (
        pooling.material.as_str(),
        pooling.name.as_deref(),
        pooling.count,
        pooling.dense,
    );
    let Groups { families, objects } = *groups;
    // Recordings that end still ringing are lower bounds on their family's ring time; pooled
    // as measured, they would pull its draws short.
    let (lengthened, censored) = super::censored::lengthen_censored(results, families, count);
    let results = &lengthened[..];
    let stiffness = match material.to_ascii_lowercase().as_str() {
        "metal" => 2.0e7,
        "wood" => 2.0e6,
        _ => 5.0e6,
    };
    let stiffness = contact_stiffness_for(stiffness, results, count, contact_exponent);
    let contact = distribution::ContactCompensation::default_strike(stiffness, contact_exponent);
    let all: Vec<&FileResult> = results.iter().collect();
    let pooled = fit_part(&all, count, &contact, material)?;
    let mut order: Vec<&str> = Vec::new();
    for f in families.unwrap_or_default() {
        if !order.contains(&f.as_str()) {
            order.push(f);
        }
    }
    let mut fams = Vec::new();
    let weights = balanced_weights(families, objects, results.len());
    if order.len() > 1 {
        let names = families.unwrap_or_default();
        for fam in &order {
            let (idx, members): (Vec<usize>, Vec<&FileResult>) = results
                .iter()
                .enumerate()
                .zip(names)
                .filter(|(_, n)| n.as_str() == *fam)
                .map(|(ir, _)| ir)
                .unzip();
            let part = fit_part(&members, count, &contact, &format!("family '{fam}'"))?;
            let mut members = exemplar_families(fam, &members, &part, count, dense.then_some(&contact))?;
            for (f, &i) in members.iter_mut().zip(&idx) {
                f.weight = weights[i];
            }
            fams.extend(members);
        }
    } else {
        let fam = order.first().copied().unwrap_or(material);
        fams = exemplar_families(fam, &all, &pooled, count, dense.then_some(&contact))?;
        for (f, &w) in fams.iter_mut().zip(&weights) {
            f.weight = w;
        }
    }
    let family_note = if fams.is_empty() {
        String::new()
    } else {
        format!(
            " Exemplar mixture, one component per recording, family-balanced (every family weighs the same, every object the same within its family, every recording the same within its object): {}.",
            fams.iter().map(|f| f.name.clone()).collect::<Vec<_>>().join(", ")
        )
    };
    let censor_note = censoring_note(&censored);
    let count = pooled.modes.count;
    let preset = Preset {
        format_version: FORMAT_VERSION,
        name: name.map_or_else(|| capitalise(material), str::to_owned),
        material_class: material.to_ascii_lowercase(),
        origin: Origin::Fitted,
        provenance: Provenance {
            sources: results
                .iter()
                .map(|r| Path::new(&r.name).file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default())
                .collect(),
            method: "tactus fit: multi-resolution Blackman-Harris peak picking, per-mode DTFT-track decay (floor- and gate-aware) refined by variable projection, joint least-squares levels; components below 20 Hz dropped; components decaying faster than a 1-ERB band (strike noise) kept in the resynthesis but not pooled; modes within 1 % merged into one (energy-preserving, with a fitted build-up); each isolated prominent spectral peak's partial, measured by its DTFT track as tactus eval does, sets the decay and energy of the mode there or is added; no pooled mode has a T60 under 40 ms; levels pre-compensated for the default strike's contact; Gaussian over the strongest modes by energy, by frequency rank with Schaefer-Strimmer shrinkage, decays relative to the EMG maximum-likelihood hybrid damping law (Sterling 2019); 30 ERB-band transient fitted to the band energy the pooled modes leave unexplained (Traer 2019 eq. 3), bands decaying slower than half the slowest pooled mode's decay (the recording's noise floor) left out; this pooled Gaussian describes the material for listings, draws come from an exemplar mixture: one component per recording centred on its own modes and transient, levels normalised so that its strongest mode's envelope peak (build-up included) is the engine's gain staging (kernel SDs ~3 dB, ~20 % decay, 0.05 octave per mode, plus a size shift common to all modes with Silverman's-rule bandwidth over the family's recordings), decays relative to the family's damping law".into(),
            date: today(),
            tool_version: env!("CARGO_PKG_VERSION").into(),
            notes: format!(
                "{} recordings, {count} modes per object (pooled). Levels raised by the inverse of the default strike's contact envelope (tau = {:.3} ms, at most {} dB), normalised per recording to its strongest mode, then shifted so the strongest mean mode level is {} dB (engine gain staging); transient levels shifted by the same amount per recording. Contact stiffness: the class default, raised until the default strike's compensation stays below its cap at the highest of each recording's strongest modes.{censor_note}{family_note}",
                results.len(),
                1e3 * contact.duration_s,
                distribution::MAX_CONTACT_BOOST_DB,
                distribution::TOP_LEVEL_DB
            ),
        },
        modes: ModeModel::Distribution(pooled.modes),
        transient: Some(pooled.transient),
        damping: pooled.damping,
        contact_stiffness_n_per_m: stiffness,
        contact_exponent,
        families: fams,
        dense: None,
    };
    preset.validate().map_err(|e| {
        anyhow::anyhow!("the fitted preset failed its own validation, which is a bug in `tactus fit` ({e})")
    })?;
    Ok(preset)
}

/// The provenance note on the censored recordings ([`super::censored::lengthen_censored`]):
/// which were lengthened by how much, which kept at their bound; empty without any.
fn censoring_note(done: &[super::censored::Lengthening]) -> String {
    if done.is_empty() {
        return String::new();
    }
    let (longer, kept): (Vec<_>, Vec<_>) = done.iter().partition(|l| l.factor.is_some());
    let mut note = format!(
        " {} recordings end still ringing (faded, cut or capped: docs/evaluation.md, \"Censored decays\"), their ring times lower bounds",
        done.len()
    );
    if !longer.is_empty() {
        note.push_str(&format!(
            "; lengthened to their family's censored (Tobit) fit of ln ring time: {}",
            longer
                .iter()
                .map(|l| format!("{} x{:.2}", l.name, l.factor.unwrap_or(1.0)))
                .collect::<Vec<_>>()
                .join(", ")
        ));
    }
    if !kept.is_empty() {
        note.push_str(&format!(
            "; kept at their bound, their family having fewer than 2 recordings that ring out: {}",
            kept.iter()
                .map(|l| l.name.as_str())
                .collect::<Vec<_>>()
                .join(", ")
        ));
    }
    note.push('.');
    note
}

/// The preset as `tactus fit` writes it: [`Preset::to_json`] with every array of numbers on one
/// line. Why: an exemplar mixture holds one covariance matrix per recording, and one number per
/// line makes a ten-recording family a 2 MB file; the values are unchanged.
pub fn fitted_preset_json(preset: &Preset) -> String {
    let pretty = preset.to_json();
    let mut out: Vec<String> = Vec::new();
    let mut in_numbers = false;
    for line in pretty.lines() {
        let t = line.trim();
        let is_number = t.trim_end_matches(',').parse::<f64>().is_ok();
        let opens = out.last().is_some_and(|l| l.ends_with('['));
        match out.last_mut() {
            Some(last) if is_number && (opens || in_numbers) => {
                if !opens {
                    last.push(' ');
                }
                last.push_str(t);
                in_numbers = true;
            }
            Some(last) if in_numbers && t.starts_with(']') => {
                last.push_str(t);
                in_numbers = false;
            }
            _ => {
                out.push(line.to_owned());
                in_numbers = false;
            }
        }
    }
    out.join("\n")
}

fn capitalise(s: &str) -> String {
    let mut c = s.chars();
    match c.next() {
        Some(f) => f.to_uppercase().collect::<String>() + c.as_str(),
        None => String::new(),
    }
}

fn today() -> String {
    // Civil date from the Unix time (Howard Hinnant's algorithm); no date crate needed.
    let secs = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_secs() as i64)
        .unwrap_or(0);
    let z = secs.div_euclid(86_400) + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    format!("{y:04}-{m:02}-{d:02}")
}

#[cfg(test)]
mod tests {
    use super::fitted_preset_json;
    use crate::preset::Preset;

    #[test]
    fn fitted_json_keeps_numbers_on_one_line_and_round_trips() {
        let p = crate::engine::materials::builtin_presets().remove(0);
        let text = fitted_preset_json(&p);
        assert!(
            text.lines()
                .all(|l| l.trim().trim_end_matches(',').parse::<f64>().is_err()),
            "a number on a line of its own"
        );
        assert!(text.lines().count() * 10 < p.to_json().lines().count());
        let back = Preset::from_json(&text, None).expect("parses");
        assert_eq!(back.to_json(), p.to_json());
    }
}
