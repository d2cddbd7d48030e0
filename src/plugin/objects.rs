//! Where the plugin's objects are drawn (docs/plugin.md, "Where objects are drawn").
//!
//! Drawing an object ([`ObjectSampler::sample`]) costs up to
//! [`crate::engine::object::MAX_REJECTION_TRIES`] Cholesky products of `3·MAX_DISTRIBUTION_MODES`
//! coordinates, about 5 M multiply-adds for the largest valid preset
//! ([`crate::preset::worst_case_preset`]), then its dense field's modes up to `MAX_MODES` and a
//! sort of them: too much for one real-time audio block, but a shipped material's draw costs
//! a twentieth of that.
//!
//! So a draw whose cost bound ([`draw_work_bound`], computed from the preset, the same on every
//! machine) fits the block's budget ([`SYNC_DRAW_WORK_PER_SAMPLE`] per sample of the block) runs
//! in `process` itself in every process mode, and the change takes effect at the block where it
//! arrives (every shipped material at blocks of 256 samples and more); so do all draws when the
//! host renders offline, and at activation. Only a costly draw in real time goes to an
//! [`ObjectWorker`], a thread of its own that draws it from its own copy of the samplers and
//! leaves it in a slot; the audio thread posts the object it needs ([`ObjectKey`]: material,
//! seed, user-preset generation), wakes the worker at once, and exchanges the ready object with
//! the engine's at the first block after it is ready ([`Engine::install_object`]: a buffer swap,
//! no allocation, no draw). Until then the previous object keeps sounding. Ringing voices keep
//! their modes either way.
//!
//! Hand-over: both slots are `Mutex`es the audio thread only ever `try_lock`s (a busy slot is
//! retried in the next block); waking the worker is a `Condvar::notify_one`, which neither
//! allocates nor blocks.

use super::user_preset::USER_SLOT;
use crate::engine::bodies::BodySet;
use crate::engine::limits::MAX_MODES;
use crate::engine::object::{EngineRng, ObjectSampler, SampledObject, MAX_REJECTION_TRIES};
use crate::engine::Engine;
use crate::preset::{ModeModel, Preset};
use rand::SeedableRng;
use std::sync::{Arc, Condvar, Mutex};
use std::thread::JoinHandle;

/// Work a synchronous draw may cost per sample of the block it runs in, in the units of
/// [`draw_work_bound`] (about one multiply-add). 2048 per sample is a draw of at most ~1 M
/// multiply-adds in a 512-sample block, about 5 % of the block's time on one core
/// (docs/plugin.md, "Where objects are drawn", gives the measured figures), paid only in the
/// block where the object changes; it covers every shipped material (bounds up to 0.29 M) at
/// blocks of 256 samples and more.
pub const SYNC_DRAW_WORK_PER_SAMPLE: u64 = 2048;

/// Work per drawn mode besides its share of the Cholesky product (exponentials, the decay law,
/// the spacing check, the copy into the best try): a generous constant so the bound stays one.
const WORK_PER_MODE: u64 = 32;

/// Work per dense-field mode (a Poisson share, a level and a log-normal decay draw) plus the
/// sort of the whole object.
const WORK_PER_DENSE_MODE: u64 = 64;

/// An upper bound on the work of one draw from `preset` ([`ObjectSampler::sample`]), in
/// multiply-adds: every rejection try ([`MAX_REJECTION_TRIES`]) of the Cholesky product over
/// the `3·count` mode coordinates, the transient's `2·bands` product, and a dense field filling
/// the object up to [`MAX_MODES`]; for a mixture, the costliest family (one family is drawn).
/// Computed from the preset alone, so it is the same on every machine and every run: whether a
/// draw runs in `process` never depends on timing.
pub fn draw_work_bound(preset: &Preset) -> u64 {
    let triangle = |c: u64| c * (c + 1) / 2;
    let part = |modes: &ModeModel, bands: Option<usize>, dense: bool| -> u64 {
        let modes = match modes {
            ModeModel::Distribution(d) => {
                let n = d.count.min(MAX_MODES) as u64;
                MAX_REJECTION_TRIES as u64 * (triangle(3 * n) + WORK_PER_MODE * n)
            }
            ModeModel::Fixed { modes } => WORK_PER_MODE * modes.len().min(MAX_MODES) as u64,
        };
        let bands = bands.map_or(0, |b| triangle(2 * b as u64) + WORK_PER_MODE * b as u64);
        let dense = if dense {
            WORK_PER_DENSE_MODE * MAX_MODES as u64
        } else {
            0
        };
        modes + bands + dense
    };
    if preset.families.is_empty() {
        part(
            &preset.modes,
            preset.transient.as_ref().map(|t| t.bands),
            preset.dense.is_some(),
        )
    } else {
        preset
            .families
            .iter()
            .map(|f| {
                part(
                    &f.modes,
                    f.transient.as_ref().map(|t| t.bands),
                    f.dense.is_some() || preset.dense.is_some(),
                )
            })
            .max()
            .unwrap_or(0)
    }
}

/// Whether a draw from `preset` fits the budget of a block of `block_len` samples
/// ([`SYNC_DRAW_WORK_PER_SAMPLE`]).
pub fn cheap_enough(preset: &Preset, block_len: usize) -> bool {
    draws_cheap_enough(preset, 1, block_len)
}

/// Whether `draws` draws from `preset` (an object's gesture bodies) fit the budget of a block
/// of `block_len` samples together.
pub fn draws_cheap_enough(preset: &Preset, draws: usize, block_len: usize) -> bool {
    draw_work_bound(preset).saturating_mul(draws as u64) <= SYNC_DRAW_WORK_PER_SAMPLE * block_len as u64
}

/// Most gesture bodies of one object: a break's dust and its most fragments.
pub const MAX_GESTURE_BODIES: usize = crate::engine::gesture::MAX_BODIES - 1;

/// Which object: material slot (already clamped to the library), seed, and for the user slot the
/// generation of its preset ([`UserPresetSlot::applied_generation`]; 0 for the other slots).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ObjectKey {
    /// Material slot.
    pub material: usize,
    /// Object seed.
    pub seed: u64,
    /// User-preset generation (0 unless `material` is the user slot).
    pub library: u64,
}

/// Which gesture bodies ([`crate::engine::bodies`]): the first `count` of `object`'s.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BodiesKey {
    /// The object they belong to.
    pub object: ObjectKey,
    /// How many.
    pub count: usize,
}

#[derive(Default)]
struct Request {
    key: Option<ObjectKey>,
    bodies: Option<BodiesKey>,
    quit: bool,
}

struct Ready {
    key: Option<ObjectKey>,
    object: SampledObject,
    bodies_key: Option<BodiesKey>,
    bodies: BodySet,
}

struct Shared {
    request: Mutex<Request>,
    wake: Condvar,
    ready: Mutex<Ready>,
}

/// The object-drawing thread and the audio thread's end of its hand-over. Dropping it stops
/// and joins the thread.
pub struct ObjectWorker {
    shared: Arc<Shared>,
    thread: Option<JoinHandle<()>>,
    /// Last key posted, so a pending request is not posted again every block.
    posted: Option<ObjectKey>,
    /// Last bodies posted.
    posted_bodies: Option<BodiesKey>,
}

impl ObjectWorker {
    /// Starts the worker with the samplers of the plugin's material library (in slot order). `user`
    /// returns the user slot's newest sampler and its generation
    /// ([`super::user_preset::UserPresetSlot::latest_sampler`]); the worker calls it when a
    /// request names a generation it does not have.
    pub fn spawn<U>(library: Vec<ObjectSampler>, user: U) -> Self
    where
        U: Fn() -> Option<(u64, ObjectSampler)> + Send + 'static,
    {
        let shared = Arc::new(Shared {
            request: Mutex::new(Request::default()),
            wake: Condvar::new(),
            ready: Mutex::new(Ready {
                key: None,
                object: SampledObject::with_capacity(),
                bodies_key: None,
                bodies: BodySet::default(),
            }),
        });
        let worker = shared.clone();
        let thread = std::thread::Builder::new()
            .name("tactus-objects".into())
            .spawn(move || run(&worker, library, &user))
            .ok();
        Self {
            shared,
            thread,
            posted: None,
            posted_bodies: None,
        }
    }

    /// Audio thread: installs the object `want` into `engine` if the worker has it ready
    /// (returns true), else posts the request (once) and returns false. Never allocates, frees
    /// or waits.
    pub fn try_install(&mut self, want: ObjectKey, engine: &mut Engine) -> bool {
        hand_over(
            &self.shared,
            &mut self.posted,
            want,
            |r| &mut r.key,
            |r| engine.install_object(want.material, want.seed, &mut r.object),
            |q| &mut q.key,
        )
    }

    /// Audio thread: installs the gesture bodies `want` into `engine` if the worker has them
    /// ready (returns true; `engine` must hold `want.object`), else posts the request (once)
    /// and returns false. Never allocates, frees or waits.
    pub fn try_install_bodies(&mut self, want: BodiesKey, engine: &mut Engine) -> bool {
        hand_over(
            &self.shared,
            &mut self.posted_bodies,
            want,
            |r| &mut r.bodies_key,
            |r| engine.install_bodies(&mut r.bodies),
            |q| &mut q.bodies,
        )
    }
}

/// The audio thread's half of one hand-over (an object, or a set of bodies): takes what the
/// worker left under `ready_key` if it is `want` (`install`, returns true), else posts `want`
/// under `request_key` once (`posted`) and wakes the worker. Only `try_lock`s: never waits.
fn hand_over<K: Copy + PartialEq>(
    shared: &Shared,
    posted: &mut Option<K>,
    want: K,
    ready_key: fn(&mut Ready) -> &mut Option<K>,
    install: impl FnOnce(&mut Ready),
    request_key: fn(&mut Request) -> &mut Option<K>,
) -> bool {
    if let Ok(mut ready) = shared.ready.try_lock() {
        match *ready_key(&mut ready) {
            Some(k) if k == want => {
                install(&mut ready);
                *ready_key(&mut ready) = None;
                return true;
            }
            // The worker finished something else (an older request, or a newer user preset
            // than the engine has yet): ask again.
            Some(_) => {
                *ready_key(&mut ready) = None;
                *posted = None;
            }
            None => {}
        }
    }
    if *posted != Some(want) {
        if let Ok(mut request) = shared.request.try_lock() {
            *request_key(&mut request) = Some(want);
            *posted = Some(want);
            drop(request);
            shared.wake.notify_one();
        }
    }
    false
}

impl Drop for ObjectWorker {
    fn drop(&mut self) {
        self.shared.request.lock().unwrap_or_else(|e| e.into_inner()).quit = true;
        self.shared.wake.notify_one();
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// The worker thread: waits for a request, draws it exactly as [`Engine::draw_object`] (or
/// [`Engine::draw_bodies`]) would (same sampler, RNG seeded with the seed), and leaves it in
/// the ready slot.
fn run(shared: &Shared, mut library: Vec<ObjectSampler>, user: &dyn Fn() -> Option<(u64, ObjectSampler)>) {
    let mut user_generation = 0;
    let mut object = SampledObject::with_capacity();
    // Allocated at the first request for bodies: most instances never play a gesture.
    let mut bodies = BodySet::default();
    loop {
        let (key, bodies_key) = {
            let mut request = shared.request.lock().unwrap_or_else(|e| e.into_inner());
            loop {
                if request.quit {
                    return;
                }
                if request.key.is_some() || request.bodies.is_some() {
                    break (request.key.take(), request.bodies.take());
                }
                request = shared.wake.wait(request).unwrap_or_else(|e| e.into_inner());
            }
        };
        if library.is_empty() {
            return;
        }
        if let Some(key) = key {
            let (material, tag) = slot(key, &mut library, &mut user_generation, user);
            library[material].sample(&mut EngineRng::seed_from_u64(key.seed), &mut object);
            let mut ready = shared.ready.lock().unwrap_or_else(|e| e.into_inner());
            std::mem::swap(&mut ready.object, &mut object);
            ready.key = Some(tag);
        }
        if let Some(want) = bodies_key {
            let (material, tag) = slot(want.object, &mut library, &mut user_generation, user);
            if bodies.capacity() < want.count {
                bodies = BodySet::with_capacity(MAX_GESTURE_BODIES);
            }
            bodies.draw(&mut library[material], want.object.seed, want.count);
            let mut ready = shared.ready.lock().unwrap_or_else(|e| e.into_inner());
            std::mem::swap(&mut ready.bodies, &mut bodies);
            ready.bodies_key = Some(BodiesKey {
                object: tag,
                count: want.count,
            });
        }
    }
}

/// The library slot of `key` (clamped), with the user slot's sampler brought up to the
/// generation the key names; and the key as it will be drawn.
fn slot(
    key: ObjectKey,
    library: &mut [ObjectSampler],
    user_generation: &mut u64,
    user: &dyn Fn() -> Option<(u64, ObjectSampler)>,
) -> (usize, ObjectKey) {
    let material = key.material.min(library.len() - 1);
    if material == USER_SLOT && key.library != *user_generation {
        if let Some((generation, sampler)) = user() {
            library[USER_SLOT] = sampler;
            *user_generation = generation;
        }
    }
    let tag = ObjectKey {
        material,
        seed: key.seed,
        library: if material == USER_SLOT {
            *user_generation
        } else {
            0
        },
    };
    (material, tag)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::engine::materials::{builtin_presets, family_presets, measured_presets};
    use crate::preset::worst_case_preset;

    /// Every shipped material draws in `process` at blocks of 256 samples and more (docs/plugin.md
    /// says so, with the bounds this prints under `--nocapture`); the largest valid preset goes
    /// to the worker at blocks up to 2048 samples.
    #[test]
    fn shipped_materials_draw_in_process_and_the_worst_case_on_the_worker() {
        for p in builtin_presets()
            .iter()
            .chain(&family_presets())
            .chain(&measured_presets())
        {
            let work = draw_work_bound(p);
            eprintln!("{}: draw work bound {work}", p.name);
            assert!(
                cheap_enough(p, 256),
                "{}: bound {work} over a 256-sample block's budget",
                p.name
            );
            assert!(!cheap_enough(p, 1), "{}: bound {work} fits one sample", p.name);
        }
        let worst = worst_case_preset();
        assert!(!cheap_enough(&worst, 2048), "bound {}", draw_work_bound(&worst));
    }
}
