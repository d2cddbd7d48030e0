//! The "User Preset" material slot: a preset file's JSON, persisted with the plugin state
//! (`#[persist = "user_preset"]`), parsed and turned into an [`ObjectSampler`] off the audio thread
//! and handed over without allocation or blocking.
//!
//! Hand-over: the GUI / state-loading thread parses the JSON, builds the sampler (allocates) and
//! leaves it in a mailbox marked fresh. The audio thread `try_lock`s the mailbox (never waits),
//! swaps the fresh sampler into the engine and leaves the *old* sampler in the mailbox, so it is
//! dropped later by the next non-audio writer rather than on the audio thread. The swap does not
//! draw an object: the plugin's object worker ([`super::objects`]) draws the new material's
//! objects from its own copy of the sampler ([`UserPresetSlot::latest_sampler`]).

use crate::engine::materials;
use crate::engine::object::ObjectSampler;
use crate::engine::Engine;
use crate::preset::Preset;
use nice_plug::params::persist::PersistentField;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Mutex, RwLock};

/// Material index of the user preset slot (after the built-ins).
pub const USER_SLOT: usize = materials::BUILTIN_SPECS.len();

/// Built-in material index used when the user preset is empty or unreadable.
pub const FALLBACK_MATERIAL: usize = 1;

/// Environment variable with a preset file loaded into the user slot when an instance is
/// created (mainly for the standalone application).
pub const ENV_USER_PRESET: &str = "TACTUS_USER_PRESET";

#[derive(Default)]
struct Mailbox {
    sampler: Option<ObjectSampler>,
    fresh: bool,
    /// [`UserPresetSlot::generation`] of `sampler`.
    generation: u64,
}

/// Persisted user preset plus the lock-free hand-over to the audio thread.
#[derive(Default)]
pub struct UserPresetSlot {
    json: RwLock<String>,
    status: RwLock<String>,
    mailbox: Mutex<Mailbox>,
    generation: AtomicU64,
    /// Generation of the sampler the audio thread last swapped into the engine.
    applied: AtomicU64,
    /// The newest sampler and its generation, for the object worker (never the audio thread).
    latest: Mutex<Option<(u64, ObjectSampler)>>,
}

/// The preset used when the user slot is empty or its JSON is unreadable.
pub fn fallback_preset() -> Preset {
    materials::builtin_presets().swap_remove(FALLBACK_MATERIAL)
}

impl UserPresetSlot {
    /// Stores `json` as the user preset (not real-time safe). An empty string clears the slot to
    /// the fallback material. A preset that does not parse or validate also installs the fallback
    /// material, keeps the text (so saving the project does not lose it) and returns the error,
    /// which [`UserPresetSlot::status`] then reports.
    pub fn set_json(&self, json: String) -> Result<(), String> {
        let parsed = if json.trim().is_empty() {
            Ok(None)
        } else {
            Preset::from_json(&json, None)
                .map(Some)
                .map_err(|e| format!("user preset: {e}"))
        };
        let (preset, result) = match parsed {
            Ok(Some(p)) => (p, Ok(())),
            Ok(None) => (fallback_preset(), Ok(())),
            Err(e) => (fallback_preset(), Err(e)),
        };
        self.install(ObjectSampler::new(&preset));
        *self.json.write().unwrap_or_else(|e| e.into_inner()) = json;
        *self.status.write().unwrap_or_else(|e| e.into_inner()) = match &result {
            Ok(()) => String::new(),
            Err(e) => e.clone(),
        };
        result
    }

    /// Reads a preset file and, if it parses, makes it the user preset. On error nothing changes
    /// except the status text.
    pub fn load_file(&self, path: &str) -> Result<(), String> {
        let result = std::fs::read_to_string(path.trim())
            .map_err(|e| format!("cannot read {path:?}: {e}"))
            .and_then(|text| {
                Preset::from_json(&text, Some(path))
                    .map(|_| text)
                    .map_err(|e| e.to_string())
            });
        match result {
            Ok(text) => self.set_json(text),
            Err(e) => {
                *self.status.write().unwrap_or_else(|p| p.into_inner()) = e.clone();
                Err(e)
            }
        }
    }

    fn install(&self, sampler: ObjectSampler) {
        let copy = sampler.clone();
        let old = {
            let mut mb = self.mailbox.lock().unwrap_or_else(|e| e.into_inner());
            let old = mb.sampler.replace(sampler);
            mb.fresh = true;
            mb.generation = self.generation.fetch_add(1, Ordering::AcqRel) + 1;
            *self.latest.lock().unwrap_or_else(|e| e.into_inner()) = Some((mb.generation, copy));
            old
        };
        drop(old);
    }

    /// The newest installed sampler and its generation (`None` before the first install: the
    /// slot then holds [`fallback_preset`], generation 0). Allocates: object worker only.
    pub fn latest_sampler(&self) -> Option<(u64, ObjectSampler)> {
        self.latest.lock().unwrap_or_else(|e| e.into_inner()).clone()
    }

    /// Generation of the sampler in the engine's user slot (0: the fallback it starts with).
    pub fn applied_generation(&self) -> u64 {
        self.applied.load(Ordering::Acquire)
    }

    /// Audio thread: swaps a freshly loaded sampler into `engine`'s user slot, keeping the current
    /// object (see [`Engine::swap_material_slot`]). Never blocks (`try_lock`), never allocates or
    /// frees. Returns true when a swap happened.
    pub fn apply_pending(&self, engine: &mut Engine) -> bool {
        // Nothing installed since the last swap: no lock taken (this runs every block).
        if self.generation.load(Ordering::Acquire) == self.applied.load(Ordering::Acquire) {
            return false;
        }
        let Ok(mut mb) = self.mailbox.try_lock() else {
            return false;
        };
        if !mb.fresh {
            return false;
        }
        mb.fresh = false;
        match mb.sampler.as_mut() {
            Some(s) => {
                engine.swap_material_slot(USER_SLOT, s);
                self.applied.store(mb.generation, Ordering::Release);
                true
            }
            None => false,
        }
    }

    /// The current JSON text (empty: no user preset).
    pub fn json(&self) -> String {
        self.json.read().unwrap_or_else(|e| e.into_inner()).clone()
    }

    /// Last error text (empty: the slot holds the preset that was asked for).
    pub fn status(&self) -> String {
        self.status.read().unwrap_or_else(|e| e.into_inner()).clone()
    }

    /// Counts installs, so a GUI can notice changes.
    pub fn generation(&self) -> u64 {
        self.generation.load(Ordering::Acquire)
    }
}

impl<'a> PersistentField<'a, String> for UserPresetSlot {
    /// Called when a state is loaded (off the audio thread; nice-plug permits allocation here).
    fn set(&self, new_value: String) {
        let _ = self.set_json(new_value);
    }

    fn map<F, R>(&self, f: F) -> R
    where
        F: Fn(&String) -> R,
    {
        f(&self.json.read().unwrap_or_else(|e| e.into_inner()))
    }
}
