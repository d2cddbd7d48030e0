//! The sustained-contact channels of the engine: scraping and rolling (docs/model.md §6–7), each a
//! force generator driving its own modal bank tuned from the current object. This module hands
//! the settings' [`super::ScrapeParams`] / [`super::RollParams`] and the per-sample speed inputs
//! to the two [`ContactChannel`]s; the force and bank code live in [`super::sustained`].

use super::object::SampledObject;
use super::sustained::channel::{ContactChannel, ModesKey, MorphVariants};
use super::sustained::{ContactKind, MotionKind, SustainedParams};
use super::voices::SLEEP_FLOOR;
use super::{Lifecycle, Settings, SpeedInput, Stats, MAX_CONTACT_SPEED};

/// What the contact banks are tuned from besides the settings: the current object, its
/// position-morph variants, its generation (incremented at every new object) and its preset's
/// contact stiffness (the level calibration's reference hit, docs/model.md §9).
pub(super) struct ObjectRef<'a> {
    pub(super) object: &'a SampledObject,
    pub(super) variants: &'a MorphVariants,
    pub(super) generation: u64,
    pub(super) contact_stiffness_n_per_m: f64,
    /// The preset's material class: the contact modulus of the scraping tip and the rolling
    /// ball on the object ([`super::sustained::contact_modulus_pa`]).
    pub(super) material_class: &'a str,
    /// The object's seed: the key of its modes' pans.
    pub(super) seed: u64,
}

/// The scraping and rolling channels and the clamped copies of their speed inputs.
pub(super) struct Contacts {
    scrape: ContactChannel,
    roll: ContactChannel,
    /// Clamped copies of the speed inputs of the current chunk (allocated by `prepare`).
    scrape_speed: Vec<f32>,
    roll_speed: Vec<f32>,
}

impl Contacts {
    /// Both channels, their noise seeded from `seed`. Allocates.
    pub(super) fn new(sample_rate_hz: f64, seed: u64) -> Self {
        Self {
            scrape: ContactChannel::new(ContactKind::Scrape, sample_rate_hz, seed),
            roll: ContactChannel::new(ContactKind::Roll, sample_rate_hz, seed ^ 0x0B_A11),
            scrape_speed: Vec::new(),
            roll_speed: Vec::new(),
        }
    }

    /// Copies `speed[pos..end]` of both inputs, clamped to ±[`MAX_CONTACT_SPEED`] (non-finite → 0,
    /// missing → 0), into the chunk's scratch; returns whether a scrape / roll input was given.
    pub(super) fn load_speeds(&mut self, speed: &SpeedInput<'_>, pos: usize, end: usize) -> (bool, bool) {
        (
            clamp_speed(speed.scrape_m_per_s, pos, end, &mut self.scrape_speed),
            clamp_speed(speed.roll_m_per_s, pos, end, &mut self.roll_speed),
        )
    }

    /// Adds both channels to `out` (the mid) and, when given, their side to `side`, for one chunk (whose speed inputs [`Contacts::load_speeds`]
    /// loaded). Counts the work in `stats`, raises `force_peak_n` to the chunk's largest force.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn render(
        &mut self,
        s: &Settings,
        obj: &ObjectRef<'_>,
        out: &mut [f32],
        mut side: Option<&mut [f32]>,
        has_scrape: bool,
        has_roll: bool,
        stats: &mut Stats,
        force_peak_n: &mut f32,
    ) {
        let len = out.len();
        let mut scrape = SustainedParams::scrape(&s.scrape);
        if has_scrape && s.scrape.motion == MotionKind::Manual {
            // Liveness comes from the buffer; the constant is unused.
            scrape.scrape_speed_m_per_s = 1.0;
        }
        let roll = SustainedParams::roll(&s.roll);
        for (ch, p, speed, radius) in [
            (
                &mut self.scrape,
                &scrape,
                has_scrape.then_some(&self.scrape_speed[..len]),
                0.0,
            ),
            (
                &mut self.roll,
                &roll,
                has_roll.then_some(&self.roll_speed[..len]),
                s.roll.radius_m,
            ),
        ] {
            ch.voice.curvature_limit = s.ablation.curvature_limit;
            ch.voice.varying_normal_force = s.ablation.varying_normal_force;
            ch.update_modes(
                ModesKey::new(obj.generation, s, radius),
                obj.object,
                obj.variants,
                obj.contact_stiffness_n_per_m,
                obj.material_class,
                obj.seed,
            );
            let (f, m) = ch.process(p, speed, out, side.as_deref_mut());
            *force_peak_n = force_peak_n.max(ch.force_peak_n());
            stats.force_samples += f;
            stats.mode_samples += m;
        }
    }

    /// On the housekeeping grid: morph while moving, sleep when silent.
    pub(super) fn housekeeping(&mut self, obj: &ObjectRef<'_>) {
        self.scrape.housekeeping(obj.object, obj.variants, SLEEP_FLOOR);
        self.roll.housekeeping(obj.object, obj.variants, SLEEP_FLOOR);
    }

    /// Whether either bank is ringing (not asleep).
    pub(super) fn any_awake(&self) -> bool {
        self.scrape.is_awake() || self.roll.is_awake()
    }

    /// Whether the scraping / rolling force generators computed the last chunk.
    pub(super) fn live(&self) -> (bool, bool) {
        (self.scrape.is_live(), self.roll.is_live())
    }

    /// Whether the scraping / rolling banks are ringing (not asleep).
    pub(super) fn awake(&self) -> (bool, bool) {
        (self.scrape.is_awake(), self.roll.is_awake())
    }
}

/// Copies `input[pos..end]` clamped to ±[`MAX_CONTACT_SPEED`] (non-finite → 0, missing → 0) into
/// `buf`; returns whether an input was given.
fn clamp_speed(input: Option<&[f32]>, pos: usize, end: usize, buf: &mut [f32]) -> bool {
    let Some(input) = input else { return false };
    let max = MAX_CONTACT_SPEED as f32;
    for (i, o) in buf[..end - pos].iter_mut().enumerate() {
        let v = input.get(pos + i).copied().unwrap_or(0.0);
        *o = if v.is_finite() { v.clamp(-max, max) } else { 0.0 };
    }
    true
}

impl Lifecycle for Contacts {
    fn prepare(&mut self, sample_rate_hz: f64, max_block: usize) {
        self.scrape_speed = vec![0.0; max_block];
        self.roll_speed = vec![0.0; max_block];
        self.scrape.prepare(sample_rate_hz, max_block);
        self.roll.prepare(sample_rate_hz, max_block);
    }

    fn reset(&mut self) {
        self.scrape.reset();
        self.roll.reset();
    }
}
