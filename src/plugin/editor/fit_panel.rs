//! The object and fit rows: the seed and New Object, loading a preset file, and fitting a
//! material from recordings (native file dialogs on a thread of their own, files dropped on the
//! window or a typed path, [`FitJob`]) with its progress and outcome.

use super::browser::set_material;
use super::style::{ACCENT, ERROR, TEXT, TEXT_WEAK};
use super::view::TactusEditor;
use crate::plugin::fit_job::{classify_drop, DropAction, FitJob, MATERIAL_CLASSES};
use crate::plugin::params::next_seed;
use crate::plugin::user_preset::USER_SLOT;
use egui::{self, RichText, Ui};
use nice_plug::prelude::*;
use nice_plug_egui::widgets::ParamSlider;
use std::path::PathBuf;
use std::sync::atomic::Ordering;
use std::sync::{Arc, OnceLock};

/// What a file dialog was opened for.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum DialogKind {
    /// Recordings to fit.
    Recordings,
    /// A folder of recordings to fit.
    Folder,
    /// A preset file for the user slot.
    Preset,
}

/// A native file dialog (rfd) running on a thread of its own, so the host's GUI thread never
/// waits for the user; its answer is read by the editor once set.
pub(super) struct Dialog {
    pub(super) kind: DialogKind,
    answer: Arc<OnceLock<Option<Vec<PathBuf>>>>,
}

impl Dialog {
    fn open(kind: DialogKind) -> Self {
        let answer = Arc::new(OnceLock::new());
        let out = answer.clone();
        // Detached: a dialog waits for the user, and closing the editor must not wait with it.
        let _ = std::thread::Builder::new()
            .name("tactus-dialog".into())
            .spawn(move || {
                let d = rfd::FileDialog::new();
                let picked = match kind {
                    DialogKind::Recordings => {
                        // Both cases: the portal's filters match names case-sensitively.
                        let exts: Vec<String> = crate::analysis::audio::EXTENSIONS
                            .iter()
                            .flat_map(|e| [e.to_string(), e.to_ascii_uppercase()])
                            .collect();
                        d.set_title("Recordings or mode tables to fit")
                            .add_filter("Recordings (WAV, FLAC, AIFF, Ogg Vorbis, MP3)", &exts)
                            .add_filter("Mode tables (docs/measured.md)", &["json", "csv", "txt"])
                            .pick_files()
                    }
                    DialogKind::Folder => d
                        .set_title("Folder of recordings to fit")
                        .pick_folder()
                        .map(|p| vec![p]),
                    DialogKind::Preset => d
                        .set_title("Tactus preset")
                        .add_filter("Tactus preset", &["json"])
                        .pick_file()
                        .map(|p| vec![p]),
                };
                let _ = out.set(picked);
            });
        Self { kind, answer }
    }
}

impl TactusEditor {
    /// Seed, "New Object", the preset loader (dialog or typed path) and the fit row. Reading
    /// and parsing a preset file and building its sampler happen here, on the GUI thread; the
    /// audio thread only swaps it in.
    pub(super) fn object_row(&mut self, ui: &mut Ui, setter: &ParamSetter) {
        let p = self.params.clone();
        ui.horizontal(|ui| {
            ui.label(RichText::new("Seed").size(12.0).color(TEXT_WEAK));
            ui.add(ParamSlider::for_param(&p.seed, setter).with_width(110.0));
            let current = p.object_seed.load(Ordering::Acquire);
            ui.label(RichText::new(format!("object {current}")).size(12.0).color(TEXT))
                .on_hover_text("Seed of the object playing now (saved with the project)");
            if ui
                .button("New Object")
                .on_hover_text("Draw another object of this material")
                .clicked()
            {
                // Same rule as the `new_object` trigger, expressed through the seed parameter so
                // the host records it.
                let next = next_seed(current) as i32;
                setter.begin_set_parameter(&p.seed);
                setter.set_parameter(&p.seed, next);
                setter.end_set_parameter(&p.seed);
            }
            ui.separator();
            let idle = self.dialog.is_none();
            if ui
                .add_enabled(idle, egui::Button::new("Load preset…"))
                .on_hover_text("A preset file (tactus fit's JSON) into the User Preset slot")
                .clicked()
            {
                self.dialog = Some(Dialog::open(DialogKind::Preset));
            }
            ui.add(
                egui::TextEdit::singleline(&mut self.typed_path)
                    .desired_width(190.0)
                    .hint_text("or type a path: preset, recordings, folder"),
            );
            if ui
                .add_enabled(!self.typed_path.trim().is_empty(), egui::Button::new("Open"))
                .on_hover_text("A .json path loads a preset; a recording or folder is fitted")
                .clicked()
            {
                let path = PathBuf::from(self.typed_path.trim());
                self.take_paths(vec![path], setter);
            }
            let status = p.user_preset.status();
            if let Some((ok, text)) = &self.message {
                let colour = if *ok { TEXT_WEAK } else { ERROR };
                ui.add(egui::Label::new(RichText::new(text).size(12.0).color(colour)).truncate())
                    .on_hover_text(text);
            } else if !status.is_empty() {
                ui.add(egui::Label::new(RichText::new(&status).size(12.0).color(ERROR)).truncate())
                    .on_hover_text(&status);
            }
        });
    }

    /// Fitting a material from recordings: dialogs, the class, progress and the outcome.
    pub(super) fn fit_row(&mut self, ui: &mut Ui) {
        ui.horizontal(|ui| {
            ui.label(RichText::new("Fit a material").size(12.0).color(TEXT_WEAK));
            let idle = self.dialog.is_none() && self.fit.is_none();
            if ui
                .add_enabled(idle, egui::Button::new("Recordings…"))
                .on_hover_text("Pick recordings (WAV, FLAC, AIFF, Ogg Vorbis, MP3) of one material; or drop files or a folder on the editor")
                .clicked()
            {
                self.dialog = Some(Dialog::open(DialogKind::Recordings));
            }
            if ui
                .add_enabled(idle, egui::Button::new("Folder…"))
                .on_hover_text("Pick a folder of recordings (WAV, FLAC, AIFF, Ogg Vorbis, MP3)")
                .clicked()
            {
                self.dialog = Some(Dialog::open(DialogKind::Folder));
            }
            ui.label(RichText::new("class").size(12.0).color(TEXT_WEAK));
            egui::ComboBox::from_id_salt("fit-class")
                .width(90.0)
                .selected_text(self.fit_settings.material_class.clone())
                .show_ui(ui, |ui| {
                    for c in MATERIAL_CLASSES {
                        ui.selectable_value(&mut self.fit_settings.material_class, c.to_string(), c);
                    }
                })
                .response
                .on_hover_text(
                    "Material class of the recordings (sets the contact stiffness a fit starts from)",
                );
            ui.separator();
            if let Some(job) = &self.fit {
                let (done, total) = job.progress();
                let frac = if total > 0 {
                    done as f32 / total as f32
                } else {
                    0.0
                };
                ui.add(
                    egui::ProgressBar::new(frac)
                        .desired_width(160.0)
                        .text(if total > 0 {
                            format!("fitting {done}/{total}")
                        } else {
                            "listing files…".into()
                        }),
                );
                if ui.button("Cancel").clicked() {
                    job.cancel();
                }
                ui.ctx().request_repaint();
            } else if let Some(d) = &self.dialog {
                let what = match d.kind {
                    DialogKind::Recordings | DialogKind::Folder => "choose recordings in the file dialog…",
                    DialogKind::Preset => "choose a preset in the file dialog…",
                };
                ui.label(RichText::new(what).size(12.0).color(TEXT_WEAK));
            } else {
                match &self.last_fit {
                    Some(Ok(r)) => {
                        let text = format!(
                            "{} fitted from {} recording{} in {:.1} s{}",
                            r.preset_name,
                            r.fitted.len(),
                            if r.fitted.len() == 1 { "" } else { "s" },
                            r.seconds,
                            if r.left_out.is_empty() {
                                String::new()
                            } else {
                                format!("; {} left out (hover)", r.left_out.len())
                            }
                        );
                        let mut tip = String::new();
                        for l in &r.left_out {
                            tip.push_str(&format!("left out {}: {}\n", l.name, l.reason));
                        }
                        for n in &r.notes {
                            tip.push_str(&format!("note: {n}\n"));
                        }
                        if tip.is_empty() {
                            tip = "every recording was fitted".into();
                        }
                        let colour = if r.left_out.is_empty() { TEXT } else { ACCENT };
                        ui.add(egui::Label::new(RichText::new(text).size(12.0).color(colour)).truncate())
                            .on_hover_text(tip);
                    }
                    Some(Err(e)) => {
                        ui.add(egui::Label::new(RichText::new(e).size(12.0).color(ERROR)).truncate())
                            .on_hover_text(e);
                    }
                    None => {
                        ui.label(
                            RichText::new("or drop recordings / a folder on the editor")
                                .size(12.0)
                                .color(TEXT_WEAK),
                        );
                    }
                }
            }
        });
    }

    /// Takes a finished dialog's answer, the files dropped on the window and a finished fit.
    pub(super) fn poll_files(&mut self, ctx: &egui::Context, setter: &ParamSetter) {
        if let Some(answer) = self.dialog.as_ref().and_then(|d| d.answer.get().cloned()) {
            self.dialog = None;
            if let Some(paths) = answer {
                self.take_paths(paths, setter);
            }
        }
        let dropped: Vec<PathBuf> = ctx.input(|i| {
            i.raw
                .dropped_files
                .iter()
                .map(|f| f.path().to_path_buf())
                .collect()
        });
        if !dropped.is_empty() {
            self.take_paths(dropped, setter);
        }
        if self.fit.as_ref().is_some_and(FitJob::finished) {
            if let Some(job) = self.fit.take() {
                let result = job.wait();
                if result.is_ok() {
                    // The job has put the fitted preset into the user slot; play it.
                    set_material(setter, &self.params, USER_SLOT);
                }
                self.last_fit = Some(result);
            }
        }
    }

    /// A preset to load or recordings to fit, from a dialog, a drop or the typed path.
    pub(super) fn take_paths(&mut self, paths: Vec<PathBuf>, setter: &ParamSetter) {
        match classify_drop(&paths) {
            DropAction::LoadPreset(path) => {
                let shown = path.display().to_string();
                match self.params.user_preset.load_file(&shown) {
                    Ok(()) => {
                        set_material(setter, &self.params, USER_SLOT);
                        self.message = Some((true, format!("loaded {shown}")));
                    }
                    Err(e) => self.message = Some((false, e)),
                }
            }
            DropAction::Fit(inputs) => {
                if self.fit.is_some() {
                    self.message = Some((false, "a fit is running; wait for it or cancel it".into()));
                    return;
                }
                self.message = None;
                self.last_fit = None;
                self.fit = Some(FitJob::start(
                    self.params.clone(),
                    inputs,
                    self.fit_settings.clone(),
                ));
            }
            DropAction::Reject(why) => self.message = Some((false, why)),
        }
    }
}
