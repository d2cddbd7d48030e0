//! A gesture's other bodies in one real-time engine (docs/model.md §11 "In the plugin"): the
//! fragments of a break, its dust, the small objects of a rattle. Each is an object of the
//! current material drawn with a seed that follows from the current object's seed
//! ([`body_seed`]), so an object always breaks into the same pieces, whoever draws them (the
//! audio thread offline, a worker in real time). A hit names its body by index: 0 is the
//! current object, `k ≥ 1` the `k`-th body of the set.
//!
//! Storage is allocated once ([`BodySet::with_capacity`]); drawing and exchanging sets never
//! allocates.

use super::object::{EngineRng, ObjectSampler, SampledObject};
use rand::SeedableRng;

/// The seed of body `k` (1-based) of the object drawn with `object_seed`: a SplitMix64 step of
/// the pair, so neighbouring objects share no bodies.
pub fn body_seed(object_seed: u64, k: usize) -> u64 {
    let mut z = object_seed
        .wrapping_mul(0x9E37_79B9_7F4A_7C15)
        .wrapping_add((k as u64).wrapping_mul(0xD1B5_4A32_D192_ED03))
        ^ 0xB0D1_E5B0_D1E5;
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// Up to a fixed number of drawn bodies and what their hits need besides the modes.
#[derive(Debug, Clone, Default)]
pub struct BodySet {
    objects: Vec<SampledObject>,
    seeds: Vec<u64>,
    /// Whether body `k − 1` has been struck since it was drawn: its first hit sounds the drawn
    /// levels, later hits perturb them, as for the object (docs/model.md §3).
    struck: Vec<bool>,
    /// Bodies drawn (`≤ capacity`).
    count: usize,
}

impl BodySet {
    /// Room for `capacity` bodies (allocates; not real-time safe).
    pub fn with_capacity(capacity: usize) -> Self {
        Self {
            objects: (0..capacity).map(|_| SampledObject::with_capacity()).collect(),
            seeds: vec![0; capacity],
            struck: vec![false; capacity],
            count: 0,
        }
    }

    /// Most bodies the set holds.
    pub fn capacity(&self) -> usize {
        self.objects.len()
    }

    /// Bodies drawn.
    pub fn len(&self) -> usize {
        self.count
    }

    /// Whether no body is drawn.
    pub fn is_empty(&self) -> bool {
        self.count == 0
    }

    /// Draws `count` bodies (at most [`BodySet::capacity`]) of the object drawn from `sampler`
    /// with `object_seed`. Never allocates.
    pub fn draw(&mut self, sampler: &mut ObjectSampler, object_seed: u64, count: usize) {
        self.count = count.min(self.capacity());
        for k in 0..self.count {
            let seed = body_seed(object_seed, k + 1);
            sampler.sample(&mut EngineRng::seed_from_u64(seed), &mut self.objects[k]);
            self.seeds[k] = seed;
            self.struck[k] = false;
        }
    }

    /// Forgets the bodies (their object changed); storage is kept.
    pub fn clear(&mut self) {
        self.count = 0;
    }

    /// Body `k` (1-based), its seed and whether it was struck before, if drawn.
    pub(super) fn body_mut(&mut self, k: usize) -> Option<(&SampledObject, u64, &mut bool)> {
        let i = k.checked_sub(1).filter(|&i| i < self.count)?;
        Some((&self.objects[i], self.seeds[i], &mut self.struck[i]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::engine::materials::builtin_presets;

    #[test]
    fn bodies_follow_from_the_object_seed_and_differ_from_each_other() {
        let preset = &builtin_presets()[0];
        let mut sampler = ObjectSampler::new(preset);
        let (mut a, mut b) = (BodySet::with_capacity(4), BodySet::with_capacity(4));
        a.draw(&mut sampler, 7, 3);
        b.draw(&mut sampler.clone(), 7, 3);
        assert_eq!(a.len(), 3);
        for k in 1..=3 {
            let (oa, sa, _) = a.body_mut(k).map(|(o, s, f)| (o.clone(), s, *f)).unwrap();
            let (ob, sb, _) = b.body_mut(k).map(|(o, s, f)| (o.clone(), s, *f)).unwrap();
            assert_eq!(sa, sb);
            assert_eq!(
                oa.modes, ob.modes,
                "body {k} is not a function of the object seed"
            );
        }
        let f1 = a.body_mut(1).unwrap().0.modes[0].freq_hz;
        let f2 = a.body_mut(2).unwrap().0.modes[0].freq_hz;
        assert_ne!(f1, f2, "two bodies drew the same object");
        assert!(a.body_mut(4).is_none() && a.body_mut(0).is_none());
        b.draw(&mut sampler, 8, 3);
        assert_ne!(b.body_mut(1).unwrap().1, a.body_mut(1).unwrap().1);
        a.draw(&mut sampler, 7, 99);
        assert_eq!(a.len(), 4, "clamped to the capacity");
    }
}
