//! The editor's look: theme colours, the dark theme, and the layout helpers every panel uses
//! (group boxes, panels, labelled parameter sliders).

use egui::{self, vec2, Color32, Rect, RichText, Stroke, StrokeKind, Ui};
use nice_plug::prelude::*;
use nice_plug_egui::widgets::ParamSlider;

// Theme colours.
pub(super) const BG: Color32 = Color32::from_rgb(0x14, 0x16, 0x1b);
pub(super) const PANEL: Color32 = Color32::from_rgb(0x1c, 0x1f, 0x26);
pub(super) const WIDGET: Color32 = Color32::from_rgb(0x2a, 0x2f, 0x3a);
pub(super) const ACCENT: Color32 = Color32::from_rgb(0xe0, 0x9a, 0x3e);
pub(super) const ACCENT_DIM: Color32 = Color32::from_rgb(0x8a, 0x5e, 0x26);
pub(super) const COOL: Color32 = Color32::from_rgb(0x4f, 0x9c, 0xd9);
pub(super) const TEXT: Color32 = Color32::from_rgb(0xd8, 0xdc, 0xe4);
pub(super) const TEXT_WEAK: Color32 = Color32::from_rgb(0x86, 0x8d, 0x9b);
pub(super) const GRID: Color32 = Color32::from_rgb(0x2c, 0x31, 0x3b);
/// The strike pad's velocity wedge; a colour nothing else paints, so a screen grab can find
/// the pad (tests/host/editor_child.py).
pub(super) const STRIKE_RAMP: Color32 = Color32::from_rgb(0x4a, 0x35, 0x1f);
pub(super) const ERROR: Color32 = Color32::from_rgb(230, 90, 80);

pub(super) fn theme(ctx: &egui::Context) {
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
pub(super) fn group(ui: &mut Ui, title: &str, rect: Rect, add: impl FnOnce(&mut Ui, f32)) {
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
pub(super) fn panel(ui: &mut Ui, title: &str, rect: Rect, add: impl FnOnce(&mut Ui)) {
    ui.painter()
        .rect(rect, 6.0, PANEL, Stroke::new(1.0, GRID), StrokeKind::Inside);
    in_rect(ui, rect.shrink(8.0), |ui| {
        ui.label(RichText::new(title).size(12.0).strong().color(ACCENT));
        add(ui);
    });
}

/// Width of the column of weak labels left of each row's control.
pub(super) const ROW_LABEL_W: f32 = 84.0;

/// A row's weak label in its fixed-width column, so the controls of every row line up.
pub(super) fn row_label(ui: &mut Ui, label: egui::Label) {
    ui.allocate_ui_with_layout(
        vec2(ROW_LABEL_W, 20.0),
        egui::Layout::left_to_right(egui::Align::Center),
        |ui| {
            ui.set_width(ROW_LABEL_W);
            ui.add(label);
        },
    );
}

/// Label left, `ParamSlider` (with its value text) right.
pub(super) fn slider<P: Param>(ui: &mut Ui, label: &str, param: &P, setter: &ParamSetter, width: f32) {
    ui.horizontal(|ui| {
        row_label(
            ui,
            egui::Label::new(RichText::new(label).color(TEXT_WEAK)).truncate(),
        );
        let slider_w = (width - ROW_LABEL_W - 90.0).max(40.0);
        ui.add(ParamSlider::for_param(param, setter).with_width(slider_w));
    });
}
