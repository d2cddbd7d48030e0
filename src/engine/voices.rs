//! The impact voices: a fixed pool, each a modal bank, a noise-band transient and a contact
//! force. Allocation (a free voice, else the quietest), stealing, merging re-strikes into the
//! voice that still rings from the same object (docs/model.md §8), choking and sleeping.
//! Never allocates after construction and [`Lifecycle::prepare`].

use super::force::{ImpactForce, ImpactParams};
use super::limits::{MAX_BANDS, MAX_MODES};
use super::modal::{ModalBank, ModeParams, STEREO_BATCH};
use super::object::ObjectBand;
use super::transient::TransientBank;
use super::{Lifecycle, Stats};

/// Default voice cap.
pub const DEFAULT_MAX_VOICES: usize = 64;

/// A voice sleeps when its output bound falls below this (−110 dBFS).
pub const SLEEP_FLOOR: f32 = 3.162e-6;

#[derive(Debug, Clone)]
pub(super) struct Voice {
    pub(super) bank: ModalBank,
    pub(super) transient: TransientBank,
    pub(super) force: ImpactForce,
    active: bool,
    key: i32,
    /// Age in samples, to steal the oldest among equally quiet voices.
    age: u64,
    /// Output bound from the last block, for stealing and sleeping.
    level: f32,
    /// What the voice's modes were tuned from: object generation, frequency scale, damping and
    /// least decay (bits). A re-hit with the same tuning and key re-excites this voice's modes instead of
    /// starting new copies of them (see [`super::Engine::set_merging_enabled`]).
    tuning: [u64; 4],
    /// Whether the voice sounds the current object (body 0), which a fracture damps.
    object: bool,
}

impl Voice {
    fn new() -> Self {
        Self {
            bank: ModalBank::with_capacity(MAX_MODES),
            transient: TransientBank::with_capacity(MAX_BANDS),
            force: ImpactForce::default(),
            active: false,
            key: -1,
            age: 0,
            level: 0.0,
            tuning: [u64::MAX; 4],
            object: false,
        }
    }
}

/// One impact, as the voices need it: the modes it excites and how.
pub(super) struct Strike<'a> {
    /// The hit's modes, already tuned and culled.
    pub(super) modes: &'a [ModeParams],
    /// Pan group of each mode ([`super::stereo`]).
    pub(super) pans: &'a [u8],
    /// Choke key (e.g. MIDI key), or −1.
    pub(super) key: i32,
    /// Whether the hit is on the current object (body 0), see [`Voice::object`].
    pub(super) object: bool,
    /// See [`Voice::tuning`].
    pub(super) tuning: [u64; 4],
    /// The contact force's parameters.
    pub(super) force: ImpactParams,
    /// The object's noise bands, or `None` when the transient is off.
    pub(super) bands: Option<&'a [ObjectBand]>,
    /// Frequency factor of the hit (pitch / size).
    pub(super) freq_scale: f64,
    /// Decay multiplier.
    pub(super) damping: f64,
    /// Factor on the transient's level per unit impulse (the modes' gains carry it already).
    pub(super) gain: f64,
    /// Seed of the transient's noise.
    pub(super) seed: u32,
}

/// The voice pool.
pub(super) struct Voices {
    sample_rate_hz: f64,
    voices: Vec<Voice>,
    /// False only when no voice is active (cleared by housekeeping, set by every impact): lets
    /// an idle block skip the voice scan.
    any: bool,
    /// Contact force of one chunk (allocated by `prepare`).
    force_buf: Vec<f32>,
    /// Scratch for merging (capacity `MAX_MODES`, allocated once).
    merge_buf: Vec<ModeParams>,
    merge_pans: Vec<u8>,
    merge_used: Vec<bool>,
}

impl Voices {
    /// A pool of `max_voices` voices (at least one). Allocates.
    pub(super) fn new(max_voices: usize, sample_rate_hz: f64) -> Self {
        Self {
            sample_rate_hz,
            voices: (0..max_voices.max(1)).map(|_| Voice::new()).collect(),
            any: false,
            force_buf: Vec::new(),
            merge_buf: Vec::with_capacity(MAX_MODES),
            merge_pans: Vec::with_capacity(MAX_MODES),
            merge_used: vec![false; MAX_MODES],
        }
    }

    /// The active voices.
    pub(super) fn active(&self) -> impl Iterator<Item = &Voice> {
        self.voices.iter().filter(|v| v.active)
    }

    /// The active voices, mutably.
    pub(super) fn active_mut(&mut self) -> impl Iterator<Item = &mut Voice> {
        self.voices.iter_mut().filter(|v| v.active)
    }

    /// Number of voices currently sounding.
    pub(super) fn count_active(&self) -> usize {
        self.active().count()
    }

    /// False when no voice can be sounding (the cheap flag; [`Voices::any_sounding`] checks).
    pub(super) fn any(&self) -> bool {
        self.any
    }

    /// Whether a voice is sounding.
    pub(super) fn any_sounding(&self) -> bool {
        self.any && self.voices.iter().any(|v| v.active)
    }

    /// Starts `hit`: on the voice that still rings from the same object, tuning and key when
    /// `merging` is on (see [`super::Engine::set_merging_enabled`]), else on a free voice or the
    /// quietest one (stolen).
    pub(super) fn start(&mut self, hit: &Strike<'_>, merging: bool) {
        // Re-strike: the voice still ringing from an earlier hit of this object (its contact
        // over) takes the new excitation on the same modes.
        let merge_into = if merging {
            self.voices.iter().position(|v| {
                v.active
                    && v.key == hit.key
                    && v.tuning == hit.tuning
                    && v.bank.active() > 0
                    && !v.force.is_active()
            })
        } else {
            None
        };
        let idx = match merge_into {
            Some(o) => {
                if self.voices[o].transient.active() > 0 {
                    self.move_transient_out(o);
                }
                self.merge_modes(o, hit.modes, hit.pans);
                o
            }
            None => {
                let i = self.free_or_quietest(None);
                let v = &mut self.voices[i];
                v.bank.reset();
                v.bank.set_modes_panned(hit.modes, hit.pans);
                i
            }
        };
        let v = &mut self.voices[idx];
        v.force.start(&hit.force, self.sample_rate_hz);
        // The transient is the part of the IR the contact excites: scale it by the contact's
        // impulse m·v·(1+e) (2·m·v for the lossless models).
        let impulse = v.force.summary().impulse_ns * hit.gain;
        v.transient.reset();
        if let Some(bands) = hit.bands {
            v.transient.start(
                bands,
                impulse,
                v.force.duration_s(),
                hit.freq_scale,
                hit.damping,
                self.sample_rate_hz,
                hit.seed,
            );
        }
        v.active = true;
        self.any = true;
        v.key = hit.key;
        v.age = 0;
        v.level = 1.0;
        v.tuning = hit.tuning;
        v.object = hit.object;
    }

    /// The object breaks for the voices started with `key` (−1: all) that sound it: each of
    /// their modes decays at least at `decay_db_per_s` from now on, its state kept (the
    /// amplitude stays continuous: no click). The voices stop being the object's: a later hit
    /// never merges into them, nor does a later fracture touch them again. Never allocates.
    pub(super) fn fracture(&mut self, key: i32, decay_db_per_s: f64) {
        for v in self.voices.iter_mut() {
            if !(v.active && v.object && (key < 0 || v.key == key)) {
                continue;
            }
            for i in 0..v.bank.active() {
                let Some(m) = v.bank.mode(i) else { break };
                if m.decay_db_per_s < decay_db_per_s {
                    v.bank.set_mode(i, ModeParams { decay_db_per_s, ..m });
                }
            }
            v.object = false;
            v.tuning = [u64::MAX; 4];
        }
    }

    /// Silences the voices started with `key` (−1: all).
    pub(super) fn choke(&mut self, key: i32) {
        for v in &mut self.voices {
            if key < 0 || v.key == key {
                v.active = false;
                v.bank.reset();
                v.transient.reset();
            }
        }
    }

    /// Moves voice `o`'s still-sounding transient to a voice of its own (a free one, else the
    /// quietest other voice), which sounds only that: no modes, no contact. With a single voice
    /// there is nowhere to move it, and the next hit's transient replaces it.
    fn move_transient_out(&mut self, o: usize) {
        let spare = self.free_or_quietest(Some(o));
        if spare == o {
            return;
        }
        let (lo, hi) = self.voices.split_at_mut(o.max(spare));
        let (a, b) = if spare < o {
            (&mut lo[spare], &mut hi[0])
        } else {
            (&mut hi[0], &mut lo[o])
        };
        std::mem::swap(&mut a.transient, &mut b.transient);
        a.bank.set_modes(&[]);
        a.force = ImpactForce::default();
        a.active = true;
        a.key = b.key;
        a.age = 0;
        a.level = 0.0;
        a.tuning = [u64::MAX; 4];
        a.object = false;
    }

    /// A free voice, else the quietest (oldest among equally quiet), never `except`.
    fn free_or_quietest(&self, except: Option<usize>) -> usize {
        let ok = |i: usize| Some(i) != except;
        if let Some(i) = (0..self.voices.len()).find(|&i| ok(i) && !self.voices[i].active) {
            return i;
        }
        let mut best: Option<usize> = None;
        for (i, v) in self.voices.iter().enumerate().filter(|(i, _)| ok(*i)) {
            let better = match best {
                None => true,
                Some(b) => {
                    let b = &self.voices[b];
                    v.level < b.level || (v.level == b.level && v.age > b.age)
                }
            };
            if better {
                best = Some(i);
            }
        }
        // Only one voice and it is `except`: share it.
        best.unwrap_or(0)
    }

    /// Gives voice `o` the new hit's modes (`new`) while keeping the state of every mode it
    /// still rings with: a mode of both gets the new hit's gain (the gain scales new excitation
    /// only), a mode only the voice has keeps ringing unexcited (gain 0), a mode only the new hit
    /// has starts from rest. Modes are matched on identical frequency and decay (same object and
    /// tuning, so identical poles). The two resonators of a mode that builds up or rings
    /// ([`super::modal::build_up_pair`], [`super::modal::ring_pair`]) differ in decay, so each
    /// meets its own and the pair is re-excited as one mode; where the culling retired one of
    /// them earlier, the new hit's one starts from rest, which by linearity is the same sound.
    /// Never allocates (`merge_buf` has `MAX_MODES` room, and both
    /// lists are subsets of one object's ≤ `MAX_MODES` modes).
    fn merge_modes(&mut self, o: usize, new: &[ModeParams], pans: &[u8]) {
        let used = &mut self.merge_used[..new.len()];
        used.fill(false);
        self.merge_buf.clear();
        self.merge_pans.clear();
        let bank = &mut self.voices[o].bank;
        for i in 0..bank.active() {
            let Some(m) = bank.mode(i) else { break };
            let hit = new.iter().enumerate().position(|(j, x)| {
                !used[j] && x.freq_hz == m.freq_hz && x.decay_db_per_s == m.decay_db_per_s
            });
            let gain = match hit {
                Some(j) => {
                    used[j] = true;
                    new[j].gain
                }
                None => 0.0,
            };
            self.merge_buf.push(ModeParams { gain, ..m });
            self.merge_pans.push(bank.pan(i));
        }
        // Kept modes first, in slot order, so each keeps its slot (and state) in `set_modes`.
        for (j, (x, _)) in new.iter().zip(used.iter()).enumerate().filter(|(_, (_, u))| !**u) {
            if self.merge_buf.len() < self.merge_buf.capacity() {
                self.merge_buf.push(*x);
                self.merge_pans
                    .push(pans.get(j).copied().unwrap_or(super::stereo::PAN_CENTRE));
            }
        }
        bank.set_modes_panned(&self.merge_buf, &self.merge_pans);
    }

    /// Adds every active voice to `out` (one chunk, ≤ the prepared maximum): the mid, and the
    /// side to `side` when given ([`super::modal::ModalBank::process_stereo`]; the noise
    /// transient is at the centre). In stereo the free-ringing voices' banks render in batches
    /// ([`ModalBank::process_stereo_free_batch`]: each bank's side is summed by parts over a
    /// pan-sorted copy of its coefficients, read in memory order as the mono kernel reads).
    /// Counts the work in `stats` and raises `force_peak_n` to the chunk's largest contact
    /// force. Returns whether a voice was active (wrote to `out`).
    pub(super) fn render(
        &mut self,
        out: &mut [f32],
        mut side: Option<&mut [f32]>,
        stats: &mut Stats,
        force_peak_n: &mut f32,
    ) -> bool {
        let len = out.len();
        let mut wrote = false;
        let mut batch: [Option<&mut ModalBank>; STEREO_BATCH] = std::array::from_fn(|_| None);
        let mut batched = 0;
        for v in self.voices.iter_mut().filter(|v| v.active) {
            wrote = true;
            stats.voice_blocks += 1;
            let force = &mut self.force_buf[..len];
            let forced = v.force.is_active() && v.force.fill(force);
            if forced {
                stats.force_samples += len as u64;
                // Impulse per sample (N·s) × fs = the sample's mean force.
                let peak = force.iter().fold(0.0f32, |m, x| m.max(x.abs()));
                *force_peak_n = force_peak_n.max(peak * self.sample_rate_hz as f32);
            }
            let input = if forced { Some(&force[..]) } else { None };
            stats.mode_samples += (v.bank.active() * len) as u64;
            stats.band_samples += (v.transient.active() * len) as u64;
            v.age += len as u64;
            match side.as_deref_mut() {
                Some(side) if !forced => {
                    v.transient.process(out);
                    batch[batched] = Some(&mut v.bank);
                    batched += 1;
                    if batched == STEREO_BATCH {
                        ModalBank::process_stereo_free_batch(&mut batch, out, side);
                        batched = 0;
                    }
                }
                Some(side) => {
                    v.bank.process_stereo(input, out, side);
                    v.transient.process(out);
                }
                None => {
                    v.bank.process(input, out);
                    v.transient.process(out);
                }
            }
        }
        if let Some(side) = side {
            ModalBank::process_stereo_free_batch(&mut batch[..batched], out, side);
        }
        wrote
    }

    /// On the housekeeping grid, after culling: updates each voice's output bound and puts the
    /// voices that fell silent (no contact, no transient, bound below [`SLEEP_FLOOR`]) to sleep.
    pub(super) fn sleep_silent(&mut self) {
        for v in self.voices.iter_mut().filter(|v| v.active) {
            // Output bound: |Σ Re z_i| ≤ Σ|z_i| ≤ √(N·Σ|z_i|²) (Cauchy–Schwarz).
            let bound = (v.bank.energy() * v.bank.active() as f32).sqrt();
            v.level = bound;
            if !v.force.is_active() && v.transient.active() == 0 && !(bound >= SLEEP_FLOOR) {
                v.active = false;
                v.bank.reset();
            }
        }
        self.any = self.voices.iter().any(|v| v.active);
    }
}

impl Lifecycle for Voices {
    fn prepare(&mut self, sample_rate_hz: f64, max_block: usize) {
        self.sample_rate_hz = sample_rate_hz;
        self.force_buf = vec![0.0; max_block];
        for v in &mut self.voices {
            v.bank.set_sample_rate(sample_rate_hz);
        }
    }

    fn reset(&mut self) {
        for v in &mut self.voices {
            v.bank.reset();
            v.transient.reset();
            v.force = ImpactForce::default();
            v.active = false;
            v.level = 0.0;
        }
        self.any = false;
    }
}
