//! Fitted recordings → a preset. [`Pooling`] says how (material, name, families, modes per
//! object, dense fields, contact); [`Pooling::preset`] pools: the recordings grouped into
//! families ([`family`]), the ring times of recordings that end still ringing lengthened by
//! each family's censored fit ([`censored`]), each family's damping law ([`damping`]) and mode and transient
//! distributions ([`distribution`]), one exemplar component per recording with its dense field
//! ([`density`]), assembled into a preset ([`preset`]), its contact exponent fitted to the
//! velocity layers among the recordings ([`velocity`]).

pub mod censored;
pub mod damping;
pub mod density;
pub mod distribution;
pub mod family;
pub mod preset;
pub mod velocity;

use crate::fit::recording::FileResult;
use crate::preset::Preset;
use crate::work::Observer;
use family::FamilyBy;
use std::path::PathBuf;

/// Modes per sampled object when none is asked for (`tactus fit --modes`).
pub const DEFAULT_COUNT: usize = crate::fit::recording::DEFAULT_MODES;

/// How fitted recordings are pooled into a preset. Built from the material with the defaults of
/// `tactus fit`, then changed field by field, e.g.
/// `Pooling::new("metal").named("Ride Cymbal").modes(16).dense(true)`.
#[derive(Debug, Clone, PartialEq)]
pub struct Pooling {
    /// Material class, e.g. wood.
    pub material: String,
    /// Display name (default: the material, capitalised).
    pub name: Option<String>,
    /// How the recordings are grouped into families (`--family-by`, default auto).
    pub family_by: FamilyBy,
    /// Modes per sampled object (default [`DEFAULT_COUNT`]).
    pub count: usize,
    /// Fit a dense mode field to each dense recording (`tactus fit --dense`; default off).
    pub dense: bool,
    /// The striker contact's exponent: `None` (default) fits it to the velocity layers among
    /// the recordings ([`velocity`]), keeping the Hunt–Crossley default without layers.
    pub contact_exponent: Option<f64>,
}

impl Pooling {
    /// The pooling `tactus fit --material MATERIAL` does with no other option.
    pub fn new(material: &str) -> Self {
        Self {
            material: material.to_owned(),
            name: None,
            family_by: FamilyBy::Auto,
            count: DEFAULT_COUNT,
            dense: false,
            contact_exponent: None,
        }
    }

    /// With the display name `name`.
    pub fn named(mut self, name: &str) -> Self {
        self.name = Some(name.to_owned());
        self
    }

    /// With the family grouping `by`.
    pub fn family_by(mut self, by: FamilyBy) -> Self {
        self.family_by = by;
        self
    }

    /// With `count` modes per sampled object.
    pub fn modes(mut self, count: usize) -> Self {
        self.count = count;
        self
    }

    /// With (or without) dense mode fields.
    pub fn dense(mut self, dense: bool) -> Self {
        self.dense = dense;
        self
    }

    /// With the contact exponent fixed at `exponent` instead of fitted to velocity layers.
    pub fn contact_exponent(mut self, exponent: f64) -> Self {
        self.contact_exponent = Some(exponent);
        self
    }

    /// The preset pooled from `results`: family-balanced, and with its contact exponent fitted
    /// to the velocity layers among them unless fixed. `observer` hears the contact fit's stage
    /// and may cancel it (the preset then keeps the default exponent).
    pub fn preset(&self, results: &[FileResult], observer: &dyn Observer) -> anyhow::Result<Preset> {
        let preset = self.assemble_default(results)?;
        self.fit_contact(preset, results, observer)
    }

    /// The preset pooled from `results` before its contact is fitted: at the fixed exponent, else
    /// the Hunt–Crossley default. Cheap beside [`Pooling::fit_contact`], for trying which
    /// recordings pool into a valid preset.
    pub fn assemble_default(&self, results: &[FileResult]) -> anyhow::Result<Preset> {
        self.assemble(
            results,
            self.contact_exponent
                .unwrap_or(crate::engine::force::HC_DEFAULT_EXPONENT),
        )
    }

    /// `preset` (from [`Pooling::assemble_default`] of `results`) with its contact exponent fitted
    /// to the velocity layers among `results`, unless the exponent is fixed.
    pub fn fit_contact(
        &self,
        preset: Preset,
        results: &[FileResult],
        observer: &dyn Observer,
    ) -> anyhow::Result<Preset> {
        match self.contact_exponent {
            Some(_) => Ok(preset),
            None => self.with_fitted_contact(preset, results, observer),
        }
    }

    /// The preset pooled from `results` for a striker contact of exponent `exponent`, grouped
    /// into families and objects by the recordings' paths.
    fn assemble(&self, results: &[FileResult], exponent: f64) -> anyhow::Result<Preset> {
        let paths: Vec<PathBuf> = results.iter().map(|r| PathBuf::from(&r.name)).collect();
        let families = family::families_of(&paths, self.family_by)?;
        let objects = family::objects_of(&paths)?;
        preset::assemble(
            self,
            results,
            &preset::Groups {
                families: families.as_deref(),
                objects: Some(&objects),
            },
            exponent,
        )
    }

    /// `preset` with its contact exponent fitted to the velocity layers among `results`;
    /// unchanged when they hold no object with two layers.
    fn with_fitted_contact(
        &self,
        preset: Preset,
        results: &[FileResult],
        observer: &dyn Observer,
    ) -> anyhow::Result<Preset> {
        let paths: Vec<PathBuf> = results.iter().map(|r| PathBuf::from(&r.name)).collect();
        let objects = velocity::layered_objects(&paths)?;
        if objects.is_empty() || observer.cancelled() {
            return Ok(preset);
        }
        observer.stage(&format!(
            "fitting the contact exponent to {} objects with velocity layers",
            objects.len()
        ));
        let Some(fit) = velocity::fit_exponent(&preset, &objects)? else {
            return Ok(preset);
        };
        let mut p = self.assemble(results, fit.exponent)?;
        p.provenance.notes.push_str(&format!(
            " Contact exponent {} fitted to {} objects with velocity layers: their median hardest/softest-layer centroid ratio is {:.3}, the draws' {:.3} (struck at the speeds the plugin plays those layers at).",
            fit.exponent, fit.objects, fit.recorded_ratio, fit.drawn_ratio
        ));
        Ok(p)
    }
}
