//! Finding a material: the grouped material list (materials, object families, measured
//! everyday objects, the user slot)
//! and the current material's provenance (where it came from, from which recordings).

use super::style::{row_label, ACCENT, ROW_LABEL_W, TEXT, TEXT_WEAK};
use super::view::TactusEditor;
use crate::engine::materials::{self, BUILTIN_SPECS, FAMILY_PRESET_NAMES, MEASURED_PRESET_NAMES};
use crate::plugin::fit_job::{provenance_summary, ProvenanceSummary};
use crate::plugin::params::{material_name, TactusParams, MATERIAL_COUNT};
use crate::plugin::user_preset::{fallback_preset, USER_SLOT};
use crate::preset::Preset;
use egui::{self, RichText, Ui};
use nice_plug::prelude::*;

impl TactusEditor {
    /// The current material's provenance: where it came from and from which recordings.
    pub(super) fn provenance_row(&mut self, ui: &mut Ui) {
        let index = (self.params.material.value().max(0) as usize).min(MATERIAL_COUNT - 1);
        let Some((name, s)) = self.provenance(index) else {
            return;
        };
        let sources = if s.sources.is_empty() {
            "no sources recorded".to_string()
        } else if s.origin == "measured" {
            format!(
                "from {} mode table{}: {}",
                s.sources.len(),
                if s.sources.len() == 1 { "" } else { "s" },
                s.sources.join(", ")
            )
        } else if s.origin == "fitted" {
            format!(
                "from {} recording{}: {}",
                s.sources.len(),
                if s.sources.len() == 1 { "" } else { "s" },
                s.sources.join(", ")
            )
        } else {
            format!("from {}", s.sources.join("; "))
        };
        let made = if s.made.is_empty() {
            String::new()
        } else {
            format!(" ({})", s.made)
        };
        let text = format!("{name}: {}{made} {sources}", s.origin);
        ui.horizontal(|ui| {
            ui.label(RichText::new("Provenance").size(12.0).color(TEXT_WEAK));
            ui.add(egui::Label::new(RichText::new(&text).size(12.0).color(TEXT)).truncate())
                .on_hover_text(s.sources.join("\n"));
        });
    }

    /// Name and provenance of material `index` (the user slot's from its current JSON).
    pub(super) fn provenance(&mut self, index: usize) -> Option<(String, ProvenanceSummary)> {
        if index == USER_SLOT {
            let slot = &self.params.user_preset;
            let generation = slot.generation();
            if self.user.as_ref().is_none_or(|(g, _, _)| *g != generation) {
                let json = slot.json();
                let preset = if json.trim().is_empty() {
                    None
                } else {
                    Preset::from_json(&json, None).ok()
                };
                let (name, summary) = match preset {
                    Some(p) => (format!("User Preset \"{}\"", p.name), provenance_summary(&p)),
                    None => {
                        let f = fallback_preset();
                        (
                            format!("User Preset (empty: plays {})", f.name),
                            provenance_summary(&f),
                        )
                    }
                };
                self.user = Some((generation, name, summary));
            }
            return self.user.as_ref().map(|(_, n, s)| (n.clone(), s.clone()));
        }
        let cached = self.shipped.get_mut(index)?;
        if cached.is_none() {
            let preset = shipped_preset(index)?;
            *cached = Some((preset.name.clone(), provenance_summary(&preset)));
        }
        cached.clone()
    }

    /// The material list, grouped: materials, object families, measured objects, the user slot.
    pub(super) fn material_menu(&mut self, ui: &mut Ui, setter: &ParamSetter, width: f32) {
        let p = self.params.clone();
        let current = (p.material.value().max(0) as usize).min(MATERIAL_COUNT - 1);
        let user_name = self
            .provenance(USER_SLOT)
            .map_or_else(|| "User Preset".to_string(), |(n, _)| n);
        let label = |i: usize| {
            if i == USER_SLOT {
                user_name.clone()
            } else {
                material_name(i as i32)
            }
        };
        ui.horizontal(|ui| {
            row_label(ui, egui::Label::new(RichText::new("Material").color(TEXT_WEAK)));
            let mut chosen = None;
            egui::ComboBox::from_id_salt("material")
                .width((width - ROW_LABEL_W - 10.0).max(60.0))
                .selected_text(label(current))
                .height(480.0)
                .show_ui(ui, |ui| {
                    for (title, range) in material_groups() {
                        ui.label(RichText::new(title).size(11.0).strong().color(ACCENT));
                        for i in range {
                            if ui.selectable_label(i == current, label(i)).clicked() {
                                chosen = Some(i);
                            }
                        }
                        ui.separator();
                    }
                });
            if let Some(i) = chosen.filter(|&i| i != current) {
                set_material(setter, &p, i);
            }
        });
    }
}

/// The material list's groups, in `material` parameter order within each group: by origin,
/// the materials (fitted from recordings and derived), the object families fitted from
/// recordings, the everyday objects fitted from measured mode tables, the user slot.
fn material_groups() -> [(&'static str, std::ops::Range<usize>); 4] {
    let n = BUILTIN_SPECS.len();
    let families = n + 1 + FAMILY_PRESET_NAMES.len();
    [
        ("MATERIALS", 0..n),
        ("OBJECT FAMILIES", n + 1..families),
        (
            "MEASURED EVERYDAY OBJECTS",
            families..families + MEASURED_PRESET_NAMES.len(),
        ),
        ("USER", USER_SLOT..USER_SLOT + 1),
    ]
}

/// The shipped preset of material `index` (not the user slot).
fn shipped_preset(index: usize) -> Option<Preset> {
    let n = BUILTIN_SPECS.len();
    if index < n {
        materials::builtin_presets().into_iter().nth(index)
    } else {
        materials::family_presets()
            .into_iter()
            .chain(materials::measured_presets())
            .nth(index.checked_sub(n + 1)?)
    }
}

/// Sets the `material` parameter as one host gesture.
pub(super) fn set_material(setter: &ParamSetter, params: &TactusParams, index: usize) {
    setter.begin_set_parameter(&params.material);
    setter.set_parameter(&params.material, index as i32);
    setter.end_set_parameter(&params.material);
}
