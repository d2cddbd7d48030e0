//! The egui editor: the window, its layout and its state. The parameter groups, declared in
//! [`super::layout`], are nice-plug-egui `ParamSlider`s (so every change is a host gesture,
//! [`super::style`]); the object and fit rows are in [`super::fit_panel`], the material list and
//! provenance in [`super::materials`], the mode view, motion pad and meters in
//! [`super::displays`], the strike pad (below the STRIKE group's rows) in [`super::strike`].
//! Everything it shows comes from the parameters, the lock-free [`EditorFeed`] or the fit job's
//! atomics; the strike pad writes the lock-free [`PadQueue`].

use super::displays::PadState;
use super::feed::{EditorFeed, ModePoint, MAX_FEED_MODES};
use super::fit_panel::Dialog;
use super::layout::{self, ParamVisitor, GROUPS};
use super::strike::StrikeState;
use super::style::{group, panel, row_label, slider, theme, ACCENT, ROW_LABEL_W, TEXT, TEXT_WEAK};
use crate::plugin::fit_job::{FitJob, FitReport, FitSettings, ProvenanceSummary};
use crate::plugin::params::{material_name, SurfaceChoice, TactusParams, MATERIAL_COUNT};
use crate::plugin::strike_pad::PadQueue;
use egui::{
    self, pos2, vec2, Align2, Color32, FontId, Margin, Rect, RichText, Sense, Stroke, StrokeKind, Ui,
};
use nice_plug::context::gui::GuiContext;
use nice_plug::editor::dpi::LogicalSize;
use nice_plug::prelude::*;
use nice_plug_egui::resizable_window::ResizableWindow;
use nice_plug_egui::{
    create_egui_editor, EguiEditor, EguiEditorState, EguiNiceSettings, Frame, NiceEguiApp, RepaintNotifier,
};
use std::collections::VecDeque;
use std::sync::Arc;
use std::time::Instant;

/// Default (and minimum) editor size in logical points.
const WIDTH: f32 = 980.0;
const HEIGHT: f32 = 775.0;
const MIN_WIDTH: f32 = 820.0;
const MIN_HEIGHT: f32 = 715.0;

/// The persistent editor window state (size). Kept by the plugin across open/close cycles.
pub fn default_state() -> Arc<EguiEditorState> {
    EguiEditorState::from_size(LogicalSize::new(WIDTH, HEIGHT), 1.0)
}

/// Builds the editor for the plugin.
pub fn create_editor(
    params: Arc<TactusParams>,
    feed: Arc<EditorFeed>,
    pad: Arc<PadQueue>,
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
        TactusEditor::new(params, feed, pad),
    )
}

/// Editor state; lives as long as the plugin's editor object, across window open/close.
pub struct TactusEditor {
    pub(super) params: Arc<TactusParams>,
    pub(super) feed: Arc<EditorFeed>,
    /// Only while a window is open (dropped in `editor_closed`).
    pub(super) gui: Option<GuiContext>,
    pub(super) modes: Vec<ModePoint>,
    pub(super) modes_generation: Option<u64>,
    /// Displayed output level (dBFS) and force (N) with a falling-needle ballistic.
    pub(super) out_db: f32,
    pub(super) force_n: Option<f32>,
    pub(super) last_frame: Option<Instant>,
    pub(super) pad: PadState,
    /// The strike pad's queue to the audio thread and its press state.
    pub(super) strike_queue: Arc<PadQueue>,
    pub(super) strike: StrikeState,
    /// Path typed into the preset / recordings field (for machines without a file dialog).
    pub(super) typed_path: String,
    /// The fit in progress, or the last one until its result has been taken.
    pub(super) fit: Option<FitJob>,
    pub(super) fit_settings: FitSettings,
    /// The outcome of the last fit, as shown.
    pub(super) last_fit: Option<Result<FitReport, String>>,
    /// A file dialog open on its own thread.
    pub(super) dialog: Option<Dialog>,
    /// Result of the last dialog, drop or typed path that was not a fit (load errors, rejects).
    pub(super) message: Option<(bool, String)>,
    /// Provenance of the shipped materials, read once when first shown (material index).
    pub(super) shipped: Vec<Option<(String, ProvenanceSummary)>>,
    /// Provenance of the user slot and the slot generation it was read at.
    pub(super) user: Option<(u64, String, ProvenanceSummary)>,
}

impl TactusEditor {
    fn new(params: Arc<TactusParams>, feed: Arc<EditorFeed>, strike_queue: Arc<PadQueue>) -> Self {
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
            strike_queue,
            strike: StrikeState::default(),
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
        // A press held while the window closes is released: a rattle would shake on.
        self.release_strike();
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

        // Parameter groups as declared in `layout::GROUPS`: columns of stacked groups, the last
        // group of each column stretched to the tallest column. Explicit rects keep the layout
        // deterministic at any window size.
        let gap = layout::GROUP_GAP;
        let area = ui.available_rect_before_wrap();
        let columns = layout::columns().max(1);
        let col_w = (area.width() - (columns - 1) as f32 * gap) / columns as f32;
        let top = area.top();
        let top_h = (0..columns).map(layout::column_height).fold(0.0, f32::max);
        let mut y = vec![top; columns];
        for (i, g) in GROUPS.iter().enumerate() {
            let last = !GROUPS[i + 1..].iter().any(|h| h.column == g.column);
            let h = if last {
                top + top_h - y[g.column]
            } else {
                layout::group_height(g.rows.len())
            };
            let x = area.left() + g.column as f32 * (col_w + gap);
            let rect = Rect::from_min_size(pos2(x, y[g.column]), vec2(col_w, h));
            y[g.column] += h + gap;
            group(ui, g.title, rect, |ui, w| {
                for row in g.rows {
                    if row.id == "material" {
                        self.material_menu(ui, setter, w);
                    } else if row.id == "surface" {
                        surface_menu(ui, setter, &p, row.label, w);
                    } else {
                        let mut draw = Slider {
                            ui: &mut *ui,
                            label: row.label,
                            setter,
                            width: w,
                        };
                        layout::visit_param(&p, row.id, &mut draw);
                    }
                }
                if g.title == layout::STRIKE_PAD_GROUP {
                    ui.add_space(6.0);
                    self.strike_pad(ui, w);
                }
            });
        }

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
}

/// The surface under the scraper and the ball as a list (synthetic, then the measured ones):
/// thirteen names read better in a list than on a slider.
fn surface_menu(ui: &mut Ui, setter: &ParamSetter, p: &TactusParams, label: &str, width: f32) {
    let current = p.surface.value() as usize;
    let name = |i: usize| SurfaceChoice::variants()[i];
    ui.horizontal(|ui| {
        row_label(ui, egui::Label::new(RichText::new(label).color(TEXT_WEAK)));
        let mut chosen = None;
        egui::ComboBox::from_id_salt("surface")
            .width((width - ROW_LABEL_W - 10.0).max(60.0))
            .selected_text(name(current))
            .height(420.0)
            .show_ui(ui, |ui| {
                for i in 0..SurfaceChoice::variants().len() {
                    if i == 1 {
                        ui.separator();
                        ui.label(RichText::new("MEASURED").size(11.0).strong().color(ACCENT));
                    }
                    if ui.selectable_label(i == current, name(i)).clicked() {
                        chosen = Some(i);
                    }
                }
            });
        if let Some(i) = chosen.filter(|&i| i != current) {
            setter.begin_set_parameter(&p.surface);
            setter.set_parameter(&p.surface, SurfaceChoice::from_index(i));
            setter.end_set_parameter(&p.surface);
        }
    });
}

/// Draws the visited parameter as a labelled slider ([`slider`]).
struct Slider<'a, 'u> {
    ui: &'u mut Ui,
    label: &'a str,
    setter: &'a ParamSetter<'a>,
    width: f32,
}

impl ParamVisitor for Slider<'_, '_> {
    fn visit<P: Param>(&mut self, param: &P) {
        slider(self.ui, self.label, param, self.setter, self.width);
    }
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
        "Drop recordings (WAV, FLAC, AIFF, Ogg Vorbis, MP3) or a folder\nto fit a material (a .json preset file to load it)",
        FontId::proportional(18.0),
        TEXT,
    );
}
