//! Objects for the plugin, drawn off the audio thread.
//!
//! Drawing an object ([`ObjectSampler::sample`]) costs up to
//! [`crate::engine::object::MAX_REJECTION_TRIES`] Cholesky products of `3·MAX_DISTRIBUTION_MODES`
//! coordinates, about 4.7 M multiply-adds for the largest valid preset
//! ([`crate::preset::worst_case_preset`]), then its dense field's modes up to `MAX_MODES` and a
//! sort of them: too much for one audio block. So in real-time mode the plugin's audio thread never draws. It
//! posts the object it needs ([`ObjectKey`]: material, seed, user-preset generation) to an
//! [`ObjectWorker`], a thread of its own that draws it from its own copy of the samplers and
//! leaves it in a slot; the audio thread then exchanges the ready object with the engine's
//! ([`Engine::install_object`]: a buffer swap, no allocation, no draw).
//!
//! Until the requested object is ready, the previous object keeps sounding: a note that arrives
//! between a change of material, seed or user preset and the object's arrival (one draw on the
//! worker, a few milliseconds at most) plays the previous object. Activation and offline
//! rendering draw synchronously instead (see `Tactus::activate` and `Tactus::process`), so
//! renders stay deterministic.
//!
//! Hand-over: both slots are `Mutex`es the audio thread only ever `try_lock`s (a busy slot is
//! retried in the next block); waking the worker is a `Condvar::notify_one`, which neither
//! allocates nor blocks.

use super::user_preset::USER_SLOT;
use crate::engine::object::{EngineRng, ObjectSampler, SampledObject};
use crate::engine::Engine;
use crate::preset::Preset;
use rand::SeedableRng;
use std::sync::{Arc, Condvar, Mutex};
use std::thread::JoinHandle;

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

#[derive(Default)]
struct Request {
    key: Option<ObjectKey>,
    quit: bool,
}

struct Ready {
    key: Option<ObjectKey>,
    object: SampledObject,
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
}

impl ObjectWorker {
    /// Starts the worker with the plugin's material library (`presets`, in slot order). `user`
    /// returns the user slot's newest sampler and its generation
    /// ([`super::user_preset::UserPresetSlot::latest_sampler`]); the worker calls it when a
    /// request names a generation it does not have.
    pub fn spawn<U>(presets: Vec<Preset>, user: U) -> Self
    where
        U: Fn() -> Option<(u64, ObjectSampler)> + Send + 'static,
    {
        let shared = Arc::new(Shared {
            request: Mutex::new(Request::default()),
            wake: Condvar::new(),
            ready: Mutex::new(Ready {
                key: None,
                object: SampledObject::with_capacity(),
            }),
        });
        let worker = shared.clone();
        let thread = std::thread::Builder::new()
            .name("tactus-objects".into())
            .spawn(move || run(&worker, &presets, &user))
            .ok();
        Self {
            shared,
            thread,
            posted: None,
        }
    }

    /// Audio thread: installs the object `want` into `engine` if the worker has it ready
    /// (returns true), else posts the request (once) and returns false. Never allocates, frees
    /// or waits.
    pub fn try_install(&mut self, want: ObjectKey, engine: &mut Engine) -> bool {
        if let Ok(mut ready) = self.shared.ready.try_lock() {
            match ready.key {
                Some(k) if k == want => {
                    engine.install_object(want.material, want.seed, &mut ready.object);
                    ready.key = None;
                    return true;
                }
                // The worker finished something else (an older request, or a newer user preset
                // than the engine has yet): ask again.
                Some(_) => {
                    ready.key = None;
                    self.posted = None;
                }
                None => {}
            }
        }
        if self.posted != Some(want) {
            if let Ok(mut request) = self.shared.request.try_lock() {
                request.key = Some(want);
                self.posted = Some(want);
                drop(request);
                self.shared.wake.notify_one();
            }
        }
        false
    }
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

/// The worker thread: waits for a request, draws it exactly as [`Engine::draw_object`] would
/// (same sampler, RNG seeded with the seed), and leaves it in the ready slot.
fn run(shared: &Shared, presets: &[Preset], user: &dyn Fn() -> Option<(u64, ObjectSampler)>) {
    let mut library: Vec<ObjectSampler> = presets.iter().map(ObjectSampler::new).collect();
    let mut user_generation = 0;
    let mut object = SampledObject::with_capacity();
    loop {
        let key = {
            let mut request = shared.request.lock().unwrap_or_else(|e| e.into_inner());
            loop {
                if request.quit {
                    return;
                }
                if let Some(k) = request.key.take() {
                    break k;
                }
                request = shared.wake.wait(request).unwrap_or_else(|e| e.into_inner());
            }
        };
        let Some(last) = library.len().checked_sub(1) else {
            return;
        };
        let material = key.material.min(last);
        if material == USER_SLOT && key.library != user_generation {
            if let Some((generation, sampler)) = user() {
                library[USER_SLOT] = sampler;
                user_generation = generation;
            }
        }
        let tag = ObjectKey {
            material,
            seed: key.seed,
            library: if material == USER_SLOT { user_generation } else { 0 },
        };
        library[material].sample(&mut EngineRng::seed_from_u64(key.seed), &mut object);
        let mut ready = shared.ready.lock().unwrap_or_else(|e| e.into_inner());
        std::mem::swap(&mut ready.object, &mut object);
        ready.key = Some(tag);
    }
}
