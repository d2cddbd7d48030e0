//! The engine's material library and its current object: one [`ObjectSampler`] per material
//! slot, the object drawn from the current one, its position-morph variants and a generation
//! that changes with every new object (the contact banks re-tune when it does).

use super::contacts::ObjectRef;
use super::object::{EngineRng, ObjectSampler, SampledObject};
use super::sustained::channel::MorphVariants;
use crate::preset::Preset;
use rand::SeedableRng;

/// The material slots and the current object.
pub(super) struct Library {
    samplers: Vec<ObjectSampler>,
    material: usize,
    object: SampledObject,
    seed: u64,
    /// Incremented at every new object, so the contact banks re-tune.
    generation: u64,
    /// Position-morph variants of the current object.
    variants: MorphVariants,
    /// The object size draws are for (sized presets pick their family by it).
    size: f64,
}

impl Library {
    /// A library of `presets` (not empty) with material `material` (clamped) current. No object
    /// is drawn yet ([`Library::draw`]); `seed` is reported until then.
    pub(super) fn new(presets: &[Preset], material: usize, seed: u64) -> Self {
        Self::with_samplers(presets.iter().map(ObjectSampler::new).collect(), material, seed)
    }

    /// As [`Library::new`], from samplers built elsewhere (not empty).
    pub(super) fn with_samplers(samplers: Vec<ObjectSampler>, material: usize, seed: u64) -> Self {
        Self {
            material: material.min(samplers.len() - 1),
            samplers,
            object: SampledObject::with_capacity(),
            seed,
            generation: 0,
            variants: MorphVariants::new(),
            size: 1.0,
        }
    }

    /// Replaces material slot `index` (not real-time safe: allocates). Out-of-range indices append.
    pub(super) fn set_slot(&mut self, index: usize, preset: &Preset) {
        let sampler = ObjectSampler::new(preset);
        match self.samplers.get_mut(index) {
            Some(s) => *s = sampler,
            None => self.samplers.push(sampler),
        }
    }

    /// Exchanges material slot `index` with `sampler` (no allocation). Out-of-range: no-op.
    pub(super) fn swap_slot(&mut self, index: usize, sampler: &mut ObjectSampler) {
        if let Some(s) = self.samplers.get_mut(index) {
            std::mem::swap(s, sampler);
        }
    }

    /// `index` clamped to the slots.
    pub(super) fn clamp(&self, index: usize) -> usize {
        index.min(self.samplers.len() - 1)
    }

    /// Sets the object size the current material draws for; true when its current object was
    /// drawn from another size class ([`ObjectSampler::size_class_at`]) and should be drawn
    /// again.
    pub(super) fn set_size(&mut self, size: f64) -> bool {
        self.size = size;
        let sampler = &mut self.samplers[self.material];
        sampler.set_size(size);
        // The object's reference size names its class (objects drawn elsewhere included).
        sampler
            .size_class_at(size)
            .is_some_and(|c| c.reference != self.object.reference_size)
    }

    /// Draws the object of material `index` (clamped) with `seed` and makes it current.
    pub(super) fn draw(&mut self, index: usize, seed: u64) {
        self.material = self.clamp(index);
        self.samplers[self.material].set_size(self.size);
        let mut rng = EngineRng::seed_from_u64(seed);
        self.samplers[self.material].sample(&mut rng, &mut self.object);
        self.installed(seed);
    }

    /// Makes `object`, drawn elsewhere from material `index` (clamped) with `seed`, current; the
    /// previous object ends up in `object` (buffers exchanged, nothing allocated or freed).
    pub(super) fn install(&mut self, index: usize, seed: u64, object: &mut SampledObject) {
        self.material = self.clamp(index);
        std::mem::swap(&mut self.object, object);
        self.installed(seed);
    }

    /// What follows every new object: its seed, morph variants and generation.
    fn installed(&mut self, seed: u64) {
        self.seed = seed;
        self.variants.draw(seed);
        self.generation = self.generation.wrapping_add(1);
    }

    /// The preset of material slot `index` (clamped).
    pub(super) fn preset_at(&self, index: usize) -> &Preset {
        self.samplers[self.clamp(index)].preset()
    }

    /// Index of the current material.
    pub(super) fn material(&self) -> usize {
        self.material
    }

    /// Number of material slots.
    pub(super) fn len(&self) -> usize {
        self.samplers.len()
    }

    /// The current material's sampler (drawing with it needs its scratch).
    pub(super) fn sampler_mut(&mut self) -> &mut ObjectSampler {
        &mut self.samplers[self.material]
    }

    /// The current material preset.
    pub(super) fn preset(&self) -> &Preset {
        self.samplers[self.material].preset()
    }

    /// The current object.
    pub(super) fn object(&self) -> &SampledObject {
        &self.object
    }

    /// Seed of the current object.
    pub(super) fn seed(&self) -> u64 {
        self.seed
    }

    /// Generation of the current object (changes with every new object).
    pub(super) fn generation(&self) -> u64 {
        self.generation
    }

    /// What the contact banks are tuned from.
    pub(super) fn object_ref(&self) -> ObjectRef<'_> {
        ObjectRef {
            object: &self.object,
            variants: &self.variants,
            generation: self.generation,
            contact_stiffness_n_per_m: self.preset().contact_stiffness_n_per_m,
            material_class: &self.preset().material_class,
            seed: self.seed(),
        }
    }
}
