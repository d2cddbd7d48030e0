//! The egui editor: parameter groups (Object, Strike, Scrape, Roll, Output) built from
//! nice-plug-egui's `ParamSlider` (so every change is a host gesture), the grouped material list
//! with the current material's provenance, fitting a material from recordings (file dialogs or
//! files dropped on the window, [`FitJob`]), the mode view, meters and the motion pad. Everything
//! it shows comes from the parameters, the lock-free [`EditorFeed`] or the fit job's atomics.

use super::feed::{EditorFeed, ModePoint, MAX_FEED_MODES};
use crate::engine::materials::{self, BUILTIN_SPECS, FAMILY_PRESET_NAMES};
use crate::plugin::fit_job::{
    classify_drop, provenance_summary, DropAction, FitJob, FitReport, FitSettings, ProvenanceSummary,
    MATERIAL_CLASSES,
};
use crate::plugin::params::{material_name, next_seed, TactusParams, MATERIAL_COUNT};
use crate::plugin::user_preset::{fallback_preset, USER_SLOT};
use crate::preset::Preset;
use egui::{
    self, pos2, vec2, Align2, Color32, FontId, Margin, Pos2, Rect, RichText, Sense, Stroke, StrokeKind, Ui,
};
use nice_plug::context::gui::GuiContext;
use nice_plug::editor::dpi::LogicalSize;
use nice_plug::prelude::*;
use nice_plug_egui::resizable_window::ResizableWindow;
use nice_plug_egui::widgets::ParamSlider;
use nice_plug_egui::{
    create_egui_editor, EguiEditor, EguiEditorState, EguiNiceSettings, Frame, NiceEguiApp, RepaintNotifier,
};
use std::collections::VecDeque;
use std::path::PathBuf;
use std::sync::atomic::Ordering;
use std::sync::{Arc, OnceLock};
use std::time::Instant;

/// Default (and minimum) editor size in logical points.
const WIDTH: f32 = 980.0;
const HEIGHT: f32 = 680.0;
const MIN_WIDTH: f32 = 820.0;
const MIN_HEIGHT: f32 = 620.0;

/// Frequency axis of the mode view (Hz, log).
const F_LO: f32 = 20.0;
const F_HI: f32 = 20_000.0;
/// Level axis of the mode view (dB below the strongest mode).
const DB_FLOOR: f32 = -90.0;
/// Pad speed scale: a drag across the whole pad in one second is this many m/s.
const PAD_M_PER_S_PER_WIDTH: f32 = 0.5;

// Theme colours.
const BG: Color32 = Color32::from_rgb(0x14, 0x16, 0x1b);
const PANEL: Color32 = Color32::from_rgb(0x1c, 0x1f, 0x26);
const WIDGET: Color32 = Color32::from_rgb(0x2a, 0x2f, 0x3a);
const ACCENT: Color32 = Color32::from_rgb(0xe0, 0x9a, 0x3e);
const ACCENT_DIM: Color32 = Color32::from_rgb(0x8a, 0x5e, 0x26);
const COOL: Color32 = Color32::from_rgb(0x4f, 0x9c, 0xd9);
const TEXT: Color32 = Color32::from_rgb(0xd8, 0xdc, 0xe4);
const TEXT_WEAK: Color32 = Color32::from_rgb(0x86, 0x8d, 0x9b);
const GRID: Color32 = Color32::from_rgb(0x2c, 0x31, 0x3b);
const ERROR: Color32 = Color32::from_rgb(230, 90, 80);

/// The persistent editor window state (size). Kept by the plugin across open/close cycles.
pub fn default_state() -> Arc<EguiEditorState> {
    EguiEditorState::from_size(LogicalSize::new(WIDTH, HEIGHT), 1.0)
}

/// Builds the editor for the plugin.
pub fn create_editor(
    params: Arc<TactusParams>,
    feed: Arc<EditorFeed>,
    state: Arc<EguiEditorState>,
) -> Option<EguiEditor<TactusEditor>> {
    let settings = EguiNiceSettings::new().with_tile("Tactus").with_resize_hint(
        ResizeHint::resizable().with_min_max_logical_size(
            Some(LogicalSize::new(MIN_WIDTH, MIN_HEIGHT)),
            Some(LogicalSize::new(2400.0, 1600.0)),
        ),
    );
    create_egui_editor(
        state,
        RepaintNotifier::new(),
        settings,
        TactusEditor::new(params, feed),
    )
}

/// Editor state; lives as long as the plugin's editor object, across window open/close.
pub struct TactusEditor {
    params: Arc<TactusParams>,
    feed: Arc<EditorFeed>,
    /// Only while a window is open (dropped in `editor_closed`).
    gui: Option<GuiContext>,
    modes: Vec<ModePoint>,
    modes_generation: Option<u64>,
    /// Displayed output level (dBFS) and force (N) with a falling-needle ballistic.
    out_db: f32,
    force_n: Option<f32>,
    last_frame: Option<Instant>,
    pad: PadState,
    /// Path typed into the preset / recordings field (for machines without a file dialog).
    typed_path: String,
    /// The fit in progress, or the last one until its result has been taken.
    fit: Option<FitJob>,
    fit_settings: FitSettings,
    /// The outcome of the last fit, as shown.
    last_fit: Option<Result<FitReport, String>>,
    /// A file dialog open on its own thread.
    dialog: Option<Dialog>,
    /// Result of the last dialog, drop or typed path that was not a fit (load errors, rejects).
    message: Option<(bool, String)>,
    /// Provenance of the shipped materials, read once when first shown (material index).
    shipped: Vec<Option<(String, ProvenanceSummary)>>,
    /// Provenance of the user slot and the slot generation it was read at.
    user: Option<(u64, String, ProvenanceSummary)>,
}

/// What a file dialog was opened for.
#[derive(Debug, Clone, Copy, PartialEq)]
enum DialogKind {
    /// WAV recordings to fit.
    Recordings,
    /// A folder of recordings to fit.
    Folder,
    /// A preset file for the user slot.
    Preset,
}

/// A native file dialog (rfd) running on a thread of its own, so the host's GUI thread never
/// waits for the user; its answer is read by the editor once set.
struct Dialog {
    kind: DialogKind,
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
                    DialogKind::Recordings => d
                        .set_title("Recordings to fit (WAV)")
                        .add_filter("WAV recordings", &["wav", "WAV"])
                        .pick_files(),
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

#[derive(Default)]
struct PadState {
    dragging: bool,
    last_pos: Option<Pos2>,
    speed: f32,
    trail: VecDeque<Pos2>,
}

impl TactusEditor {
    fn new(params: Arc<TactusParams>, feed: Arc<EditorFeed>) -> Self {
        Self {
            params,
            feed,
            gui: None,
            modes: Vec::with_capacity(MAX_FEED_MODES),
            modes_generation: None,
            out_db: -120.0,
            force_n: None,
            last_frame: None,
            pad: PadState {
                trail: VecDeque::with_capacity(64),
                ..PadState::default()
            },
            typed_path: String::new(),
            fit: None,
            fit_settings: FitSettings::default(),
            last_fit: None,
            dialog: None,
            message: None,
            shipped: vec![None; MATERIAL_COUNT],
            user: None,
        }
    }
}

fn theme(ctx: &egui::Context) {
    ctx.set_theme(egui::Theme::Dark);
    let mut v = egui::Visuals::dark();
    v.panel_fill = BG;
    v.window_fill = PANEL;
    v.extreme_bg_color = Color32::from_rgb(0x0f, 0x11, 0x15);
    v.faint_bg_color = PANEL;
    v.override_text_color = Some(TEXT);
    v.selection.bg_fill = ACCENT_DIM;
    v.selection.stroke = Stroke::new(1.0, ACCENT);
    v.widgets.inactive.bg_fill = WIDGET;
    v.widgets.inactive.weak_bg_fill = WIDGET;
    v.widgets.hovered.bg_fill = Color32::from_rgb(0x34, 0x3a, 0x47);
    v.widgets.active.bg_fill = Color32::from_rgb(0x3c, 0x43, 0x52);
    v.widgets.noninteractive.bg_stroke = Stroke::new(1.0, GRID);
    ctx.set_visuals_of(egui::Theme::Dark, v);
    ctx.style_mut_of(egui::Theme::Dark, |s| {
        s.spacing.item_spacing = vec2(8.0, 5.0);
        s.spacing.interact_size.y = 20.0;
    });
}

impl NiceEguiApp for TactusEditor {
    fn build(
        &mut self,
        egui_ctx: egui::Context,
        nice_gui_ctx: GuiContext,
        _frame: &mut Frame,
    ) -> Result<(), nice_plug_egui::baseview::HandlerError> {
        theme(&egui_ctx);
        self.gui = Some(nice_gui_ctx);
        self.modes_generation = None;
        Ok(())
    }

    fn ui(&mut self, ui: &mut Ui, _frame: &mut Frame) {
        let Some(gui) = self.gui.clone() else {
            return;
        };
        let setter = gui.param_setter();
        let now = Instant::now();
        let dt = self
            .last_frame
            .map_or(1.0 / 60.0, |t| (now - t).as_secs_f32().clamp(1e-3, 0.25));
        self.last_frame = Some(now);
        self.poll_feed(dt);
        self.poll_files(ui.ctx(), &setter);

        ResizableWindow::new("tactus-editor")
            .min_size(vec2(MIN_WIDTH, MIN_HEIGHT))
            .show(ui, |ui| {
                egui::Frame::new()
                    .inner_margin(Margin::same(12))
                    .show(ui, |ui| self.layout(ui, &setter, dt));
            });
        if ui.ctx().input(|i| !i.raw.hovered_files.is_empty()) {
            drop_overlay(ui);
        }
        // Meters and the pad animate; 30 fps is plenty while the window is open.
        ui.ctx().request_repaint_after_secs(1.0 / 30.0);
    }

    fn editor_closed(&mut self) {
        self.gui = None;
        self.last_frame = None;
        self.pad = PadState {
            trail: VecDeque::with_capacity(64),
            ..PadState::default()
        };
    }
}

impl TactusEditor {
    fn poll_feed(&mut self, dt: f32) {
        if self.modes_generation != Some(self.feed.generation()) {
            if let Some(g) = self.feed.read_modes(&mut self.modes) {
                self.modes_generation = Some(g);
            }
        }
        let peak = self.feed.take_output_peak();
        let peak_db = if peak > 0.0 { 20.0 * peak.log10() } else { -120.0 };
        // Instant attack, 24 dB/s release.
        self.out_db = peak_db.max(self.out_db - 24.0 * dt).max(-120.0);
        if let Some(f) = self.feed.take_force_peak() {
            let prev = self.force_n.unwrap_or(0.0);
            self.force_n = Some(f.max(prev * (-dt / 0.3).exp()));
        }
    }

    fn layout(&mut self, ui: &mut Ui, setter: &ParamSetter, dt: f32) {
        let p = self.params.clone();
        // Header.
        ui.horizontal(|ui| {
            ui.label(RichText::new("TACTUS").size(22.0).strong().color(ACCENT));
            ui.label(
                RichText::new("contact sounds · impacts, scraping, rolling")
                    .size(13.0)
                    .color(TEXT_WEAK),
            );
            ui.with_layout(egui::Layout::right_to_left(egui::Align::Center), |ui| {
                ui.label(
                    RichText::new(material_name(p.material.value()))
                        .size(16.0)
                        .color(TEXT),
                );
                ui.label(RichText::new("material").size(12.0).color(TEXT_WEAK));
            });
        });
        ui.add_space(4.0);
        self.object_row(ui, setter);
        self.fit_row(ui);
        self.provenance_row(ui);
        ui.add_space(6.0);

        // Parameter groups: four columns, Output under Roll. Explicit rects keep the layout
        // deterministic at any window size.
        let gap = 10.0;
        let area = ui.available_rect_before_wrap();
        let col_w = (area.width() - 3.0 * gap) / 4.0;
        let row_h = 31.0;
        let group_h = |rows: usize| 36.0 + rows as f32 * row_h;
        let top_h = group_h(4) + gap + group_h(1);
        let col = |i: usize, y: f32, rows: usize| {
            Rect::from_min_size(
                pos2(area.left() + i as f32 * (col_w + gap), y),
                vec2(col_w, if rows == 5 { top_h } else { group_h(rows) }),
            )
        };
        let top = area.top();
        group(ui, "OBJECT", col(0, top, 5), |ui, w| {
            self.material_menu(ui, setter, w);
            slider(ui, "Size", &p.size, setter, w);
            slider(ui, "Damping", &p.damping, setter, w);
            slider(ui, "Variation", &p.variation, setter, w);
            slider(ui, "Quality", &p.quality, setter, w);
        });
        group(ui, "STRIKE", col(1, top, 5), |ui, w| {
            slider(ui, "Mass", &p.mass, setter, w);
            slider(ui, "Velocity", &p.velocity, setter, w);
            slider(ui, "Hardness", &p.hardness, setter, w);
            slider(ui, "Contact", &p.contact_model, setter, w);
            slider(ui, "Keys", &p.note_mode, setter, w);
        });
        group(ui, "SCRAPE", col(2, top, 5), |ui, w| {
            slider(ui, "Speed", &p.scrape_speed, setter, w);
            slider(ui, "Motion", &p.scrape_motion, setter, w);
            slider(ui, "Pressure", &p.scrape_pressure, setter, w);
            slider(ui, "Roughness", &p.roughness, setter, w);
        });
        let roll = col(3, top, 4);
        group(ui, "ROLL", roll, |ui, w| {
            slider(ui, "Speed", &p.roll_speed, setter, w);
            slider(ui, "Radius", &p.roll_radius, setter, w);
            slider(ui, "Eccentricity", &p.roll_eccentricity, setter, w);
            slider(ui, "Pressure", &p.roll_pressure, setter, w);
        });
        let out = Rect::from_min_max(
            pos2(roll.left(), roll.bottom() + gap),
            pos2(roll.right(), top + top_h),
        );
        group(ui, "OUTPUT", out, |ui, w| {
            slider(ui, "Gain", &p.gain, setter, w);
        });

        // Bottom row: mode view | motion pad | meters.
        let y0 = top + top_h + gap;
        let h = (area.bottom() - y0).max(120.0);
        let meters_w = 110.0;
        let pad_w = h.min(area.width() * 0.3);
        let view_w = area.width() - pad_w - meters_w - 2.0 * gap;
        let view = Rect::from_min_size(pos2(area.left(), y0), vec2(view_w, h));
        let pad = Rect::from_min_size(pos2(view.right() + gap, y0), vec2(pad_w, h));
        let meters = Rect::from_min_size(pos2(pad.right() + gap, y0), vec2(meters_w, h));
        panel(ui, "MODES", view, |ui| self.mode_view(ui));
        panel(ui, "MOTION PAD", pad, |ui| self.motion_pad(ui, setter, dt));
        panel(ui, "METERS", meters, |ui| self.meters(ui));
        ui.allocate_rect(area, Sense::hover());
    }

    /// Seed, "New Object", the preset loader (dialog or typed path) and the fit row. Reading
    /// and parsing a preset file and building its sampler happen here, on the GUI thread; the
    /// audio thread only swaps it in.
    fn object_row(&mut self, ui: &mut Ui, setter: &ParamSetter) {
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
                    .hint_text("or type a path: preset, WAVs, folder"),
            );
            if ui
                .add_enabled(!self.typed_path.trim().is_empty(), egui::Button::new("Open"))
                .on_hover_text("A .json path loads a preset; a WAV file or folder is fitted")
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
    fn fit_row(&mut self, ui: &mut Ui) {
        ui.horizontal(|ui| {
            ui.label(RichText::new("Fit a material").size(12.0).color(TEXT_WEAK));
            let idle = self.dialog.is_none() && self.fit.is_none();
            if ui
                .add_enabled(idle, egui::Button::new("Recordings…"))
                .on_hover_text("Pick WAV recordings of one material; or drop files or a folder on the editor")
                .clicked()
            {
                self.dialog = Some(Dialog::open(DialogKind::Recordings));
            }
            if ui
                .add_enabled(idle, egui::Button::new("Folder…"))
                .on_hover_text("Pick a folder of WAV recordings")
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
                            RichText::new("or drop WAV files / a folder on the editor")
                                .size(12.0)
                                .color(TEXT_WEAK),
                        );
                    }
                }
            }
        });
    }

    /// The current material's provenance: where it came from and from which recordings.
    fn provenance_row(&mut self, ui: &mut Ui) {
        let index = (self.params.material.value().max(0) as usize).min(MATERIAL_COUNT - 1);
        let Some((name, s)) = self.provenance(index) else {
            return;
        };
        let sources = if s.sources.is_empty() {
            "no sources recorded".to_string()
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
    fn provenance(&mut self, index: usize) -> Option<(String, ProvenanceSummary)> {
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

    /// Takes a finished dialog's answer, the files dropped on the window and a finished fit.
    fn poll_files(&mut self, ctx: &egui::Context, setter: &ParamSetter) {
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
    fn take_paths(&mut self, paths: Vec<PathBuf>, setter: &ParamSetter) {
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

    /// The material list, grouped: materials, object families, the user slot.
    fn material_menu(&mut self, ui: &mut Ui, setter: &ParamSetter, width: f32) {
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
            let label_w = 84.0;
            ui.allocate_ui_with_layout(
                vec2(label_w, 20.0),
                egui::Layout::left_to_right(egui::Align::Center),
                |ui| {
                    ui.set_width(label_w);
                    ui.label(RichText::new("Material").color(TEXT_WEAK));
                },
            );
            let mut chosen = None;
            egui::ComboBox::from_id_salt("material")
                .width((width - label_w - 10.0).max(60.0))
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

    /// Frequency (log) × level bars; colour and opacity follow the decay rate.
    fn mode_view(&self, ui: &mut Ui) {
        let size = self.params.size.value().max(1e-3);
        let damping = self.params.damping.value().max(1e-3);
        let quality = self.params.quality.value();
        let (resp, painter) = ui.allocate_painter(ui.available_size(), Sense::hover());
        let r = resp.rect;
        painter.rect_filled(r, 4.0, ui.visuals().extreme_bg_color);
        let plot = Rect::from_min_max(r.min + vec2(34.0, 8.0), r.max - vec2(8.0, 20.0));
        let x_of = |f: f32| {
            let t = (f.max(F_LO) / F_LO).ln() / (F_HI / F_LO).ln();
            plot.left() + t.clamp(0.0, 1.0) * plot.width()
        };
        let y_of = |db: f32| plot.top() + (db / DB_FLOOR).clamp(0.0, 1.0) * plot.height();
        let small = FontId::proportional(10.0);
        for f in [
            20.0, 50.0, 100.0, 200.0, 500.0, 1000.0, 2000.0, 5000.0, 10000.0, 20000.0,
        ] {
            let x = x_of(f);
            painter.line_segment(
                [pos2(x, plot.top()), pos2(x, plot.bottom())],
                Stroke::new(1.0, GRID),
            );
            let label = if f >= 1000.0 {
                format!("{}k", f / 1000.0)
            } else {
                format!("{f}")
            };
            painter.text(
                pos2(x, plot.bottom() + 3.0),
                Align2::CENTER_TOP,
                label,
                small.clone(),
                TEXT_WEAK,
            );
        }
        for db in [0.0, -20.0, -40.0, -60.0, -80.0] {
            let y = y_of(db);
            painter.line_segment(
                [pos2(plot.left(), y), pos2(plot.right(), y)],
                Stroke::new(1.0, GRID),
            );
            painter.text(
                pos2(plot.left() - 4.0, y),
                Align2::RIGHT_CENTER,
                format!("{db:.0}"),
                small.clone(),
                TEXT_WEAK,
            );
        }
        // Culling threshold (Quality): modes below it are not computed.
        let yq = y_of(-quality);
        if -quality > DB_FLOOR {
            painter.line_segment(
                [pos2(plot.left(), yq), pos2(plot.right(), yq)],
                Stroke::new(1.0, COOL.gamma_multiply(0.6)),
            );
            painter.text(
                pos2(plot.right() - 2.0, yq - 2.0),
                Align2::RIGHT_BOTTOM,
                "quality cut",
                small.clone(),
                COOL,
            );
        }
        if self.modes.is_empty() {
            painter.text(
                plot.center(),
                Align2::CENTER_CENTER,
                "waiting for the audio engine…",
                FontId::proportional(13.0),
                TEXT_WEAK,
            );
            return;
        }
        let hover = resp.hover_pos();
        let mut nearest: Option<(f32, ModePoint, f32)> = None;
        // Weakest first, so strong modes draw on top.
        let mut order: Vec<usize> = (0..self.modes.len()).collect();
        order.sort_by(|&a, &b| self.modes[a].level_db.total_cmp(&self.modes[b].level_db));
        for i in order {
            let m = self.modes[i];
            let f = m.freq_hz / size;
            let decay = m.decay_db_per_s * damping;
            // Long ring (≤ 3 dB/s) → bright amber, fast decay (≥ 3000 dB/s) → faint blue.
            let t = ((decay.max(3.0) / 3.0).log10() / 3.0).clamp(0.0, 1.0);
            let colour = lerp_colour(ACCENT, COOL, t).gamma_multiply(1.0 - 0.65 * t);
            let x = x_of(f);
            let top = y_of(m.level_db);
            let below = m.level_db < -quality;
            let colour = if below { colour.gamma_multiply(0.3) } else { colour };
            painter.line_segment([pos2(x, plot.bottom()), pos2(x, top)], Stroke::new(2.0, colour));
            painter.circle_filled(pos2(x, top), 2.2, colour);
            if let Some(h) = hover {
                let d = (h.x - x).abs();
                if nearest.is_none_or(|(nd, _, _)| d < nd) {
                    nearest = Some((d, m, f));
                }
            }
        }
        if let Some((d, m, f)) = nearest {
            if d < 12.0 {
                let text = format!(
                    "{:.1} Hz   {:.1} dB   {:.0} dB/s",
                    f,
                    m.level_db,
                    m.decay_db_per_s * damping
                );
                painter.text(
                    pos2(plot.left() + 6.0, plot.top() + 4.0),
                    Align2::LEFT_TOP,
                    text,
                    FontId::monospace(11.0),
                    TEXT,
                );
            }
        }
        painter.text(
            pos2(plot.right() - 2.0, plot.top() + 4.0),
            Align2::RIGHT_TOP,
            format!("{} modes · colour = decay", self.modes.len()),
            small,
            TEXT_WEAK,
        );
    }

    /// Dragging sets Scrape Speed from the drag velocity, as one automation gesture.
    fn motion_pad(&mut self, ui: &mut Ui, setter: &ParamSetter, dt: f32) {
        let param = &self.params.scrape_speed;
        let (resp, painter) = ui.allocate_painter(ui.available_size(), Sense::drag());
        let r = resp.rect;
        painter.rect_filled(r, 4.0, ui.visuals().extreme_bg_color);
        let step = r.width() / 8.0;
        for i in 1..8 {
            let x = r.left() + step * i as f32;
            painter.line_segment([pos2(x, r.top()), pos2(x, r.bottom())], (1.0, GRID));
        }
        let vstep = r.height() / 8.0;
        for i in 1..8 {
            let y = r.top() + vstep * i as f32;
            painter.line_segment([pos2(r.left(), y), pos2(r.right(), y)], (1.0, GRID));
        }

        let pad = &mut self.pad;
        if resp.drag_started() {
            setter.begin_set_parameter(param);
            pad.dragging = true;
            pad.last_pos = resp.interact_pointer_pos();
            pad.speed = 0.0;
            pad.trail.clear();
        }
        if pad.dragging {
            if let Some(pos) = resp.interact_pointer_pos() {
                let moved = pad.last_pos.map_or(0.0, |l| (pos - l).length());
                pad.last_pos = Some(pos);
                let target = moved / dt / r.width().max(1.0) * PAD_M_PER_S_PER_WIDTH;
                // One-pole smoothing (~80 ms) so a jittery mouse does not buzz.
                let a = 1.0 - (-dt / 0.08).exp();
                pad.speed += a * (target - pad.speed);
                if pad.trail.len() == 64 {
                    pad.trail.pop_front();
                }
                pad.trail.push_back(pos);
            }
            let (lo, hi) = (param.preview_plain(0.0), param.preview_plain(1.0));
            let v = pad.speed.clamp(lo, hi);
            if (v - param.value()).abs() > 1e-4 {
                setter.set_parameter(param, v);
            }
            ui.ctx().request_repaint();
        }
        if resp.drag_stopped() && pad.dragging {
            // Lifting the scraper stops the scrape.
            setter.set_parameter(param, 0.0);
            setter.end_set_parameter(param);
            pad.dragging = false;
            pad.last_pos = None;
            pad.speed = 0.0;
        }
        if !pad.dragging && !pad.trail.is_empty() {
            pad.trail.pop_front();
        }
        let n = pad.trail.len();
        for (i, (a, b)) in pad.trail.iter().zip(pad.trail.iter().skip(1)).enumerate() {
            let alpha = (i + 1) as f32 / n as f32;
            painter.line_segment([*a, *b], Stroke::new(3.0 * alpha, ACCENT.gamma_multiply(alpha)));
        }
        if let Some(p) = pad.trail.back() {
            painter.circle_filled(*p, 5.0, ACCENT);
        }
        painter.text(
            r.left_bottom() + vec2(6.0, -6.0),
            Align2::LEFT_BOTTOM,
            format!("scrape {:.3} m/s", param.value()),
            FontId::monospace(11.0),
            TEXT,
        );
        if n == 0 {
            painter.text(
                r.center(),
                Align2::CENTER_CENTER,
                "drag to scrape\nspeed = drag velocity",
                FontId::proportional(12.0),
                TEXT_WEAK,
            );
        }
        resp.on_hover_cursor(egui::CursorIcon::Crosshair);
    }

    fn meters(&self, ui: &mut Ui) {
        let (resp, painter) = ui.allocate_painter(ui.available_size(), Sense::hover());
        let r = resp.rect;
        let w = (r.width() - 10.0) / 2.0;
        let out = Rect::from_min_size(r.min + vec2(0.0, 16.0), vec2(w, r.height() - 32.0));
        let force = out.translate(vec2(w + 10.0, 0.0));
        let small = FontId::proportional(10.0);
        // Output: -60..+6 dBFS.
        let t = ((self.out_db + 60.0) / 66.0).clamp(0.0, 1.0);
        meter_bar(
            &painter,
            out,
            t,
            if self.out_db > 0.0 {
                Color32::from_rgb(0xe0, 0x4a, 0x3e)
            } else {
                ACCENT
            },
        );
        painter.text(
            out.center_top() - vec2(0.0, 3.0),
            Align2::CENTER_BOTTOM,
            "out",
            small.clone(),
            TEXT_WEAK,
        );
        let db_text = if self.out_db <= -119.0 {
            "-inf".to_string()
        } else {
            format!("{:.0}", self.out_db)
        };
        painter.text(
            out.center_bottom() + vec2(0.0, 3.0),
            Align2::CENTER_TOP,
            db_text,
            small.clone(),
            TEXT,
        );
        // Contact force: log scale 0.01..1000 N.
        painter.text(
            force.center_top() - vec2(0.0, 3.0),
            Align2::CENTER_BOTTOM,
            "force",
            small.clone(),
            TEXT_WEAK,
        );
        match self.force_n {
            Some(f) => {
                let t = ((f.max(0.01) / 0.01).log10() / 5.0).clamp(0.0, 1.0);
                meter_bar(&painter, force, t, COOL);
                painter.text(
                    force.center_bottom() + vec2(0.0, 3.0),
                    Align2::CENTER_TOP,
                    format!("{f:.1} N"),
                    small,
                    TEXT,
                );
            }
            None => {
                meter_bar(&painter, force, 0.0, COOL);
                painter.text(
                    force.center_bottom() + vec2(0.0, 3.0),
                    Align2::CENTER_TOP,
                    "—",
                    small,
                    TEXT_WEAK,
                );
            }
        }
    }
}

fn meter_bar(painter: &egui::Painter, r: Rect, t: f32, colour: Color32) {
    painter.rect_filled(r, 2.0, Color32::from_rgb(0x0f, 0x11, 0x15));
    let filled = Rect::from_min_max(pos2(r.left(), r.bottom() - t * r.height()), r.max);
    painter.rect_filled(filled, 2.0, colour);
    painter.rect_stroke(r, 2.0, Stroke::new(1.0, GRID), StrokeKind::Inside);
}

fn lerp_colour(a: Color32, b: Color32, t: f32) -> Color32 {
    let l = |x: u8, y: u8| (x as f32 + (y as f32 - x as f32) * t).round() as u8;
    Color32::from_rgb(l(a.r(), b.r()), l(a.g(), b.g()), l(a.b(), b.b()))
}

/// Runs `add` in a top-down child `Ui` confined to `rect`.
fn in_rect(ui: &mut Ui, rect: Rect, add: impl FnOnce(&mut Ui)) {
    let mut child = ui.new_child(
        egui::UiBuilder::new()
            .max_rect(rect)
            .layout(egui::Layout::top_down(egui::Align::Min)),
    );
    child.set_clip_rect(rect.intersect(ui.clip_rect()));
    add(&mut child);
}

/// A titled group box filling `rect`; `add` receives the inner width.
fn group(ui: &mut Ui, title: &str, rect: Rect, add: impl FnOnce(&mut Ui, f32)) {
    ui.painter()
        .rect(rect, 6.0, PANEL, Stroke::new(1.0, GRID), StrokeKind::Inside);
    let inner = rect.shrink(10.0);
    in_rect(ui, inner, |ui| {
        ui.label(RichText::new(title).size(12.0).strong().color(ACCENT));
        ui.add_space(4.0);
        add(ui, inner.width());
    });
}

/// A titled panel filling `rect` for the bottom row.
fn panel(ui: &mut Ui, title: &str, rect: Rect, add: impl FnOnce(&mut Ui)) {
    ui.painter()
        .rect(rect, 6.0, PANEL, Stroke::new(1.0, GRID), StrokeKind::Inside);
    in_rect(ui, rect.shrink(8.0), |ui| {
        ui.label(RichText::new(title).size(12.0).strong().color(ACCENT));
        add(ui);
    });
}

/// Label left, `ParamSlider` (with its value text) right.
fn slider<P: Param>(ui: &mut Ui, label: &str, param: &P, setter: &ParamSetter, width: f32) {
    ui.horizontal(|ui| {
        let label_w = 84.0;
        ui.allocate_ui_with_layout(
            vec2(label_w, 20.0),
            egui::Layout::left_to_right(egui::Align::Center),
            |ui| {
                ui.set_width(label_w);
                ui.add(egui::Label::new(RichText::new(label).color(TEXT_WEAK)).truncate());
            },
        );
        let slider_w = (width - label_w - 90.0).max(40.0);
        ui.add(ParamSlider::for_param(param, setter).with_width(slider_w));
    });
}

/// The material list's groups, in `material` parameter order within each group.
fn material_groups() -> [(&'static str, std::ops::Range<usize>); 3] {
    let n = BUILTIN_SPECS.len();
    [
        ("MATERIALS", 0..n),
        ("OBJECT FAMILIES", n + 1..n + 1 + FAMILY_PRESET_NAMES.len()),
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
            .nth(index.checked_sub(n + 1)?)
    }
}

/// Sets the `material` parameter as one host gesture.
fn set_material(setter: &ParamSetter, params: &TactusParams, index: usize) {
    setter.begin_set_parameter(&params.material);
    setter.set_parameter(&params.material, index as i32);
    setter.end_set_parameter(&params.material);
}

/// Shown while files are dragged over the window.
fn drop_overlay(ui: &mut Ui) {
    let r = ui.ctx().content_rect();
    let painter = ui.ctx().layer_painter(egui::LayerId::new(
        egui::Order::Foreground,
        egui::Id::unique("tactus-drop-overlay"),
    ));
    painter.rect_filled(r, 0.0, Color32::from_black_alpha(170));
    painter.rect_stroke(r.shrink(6.0), 8.0, Stroke::new(2.0, ACCENT), StrokeKind::Inside);
    painter.text(
        r.center(),
        Align2::CENTER_CENTER,
        "Drop WAV recordings or a folder to fit a material\n(a .json preset file to load it)",
        FontId::proportional(18.0),
        TEXT,
    );
}
