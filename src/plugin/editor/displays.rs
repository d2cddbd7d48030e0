//! The bottom row: the mode view (frequency × level, coloured by decay), the motion pad
//! (drag velocity → Scrape Speed) and the output and force meters.

use super::feed::ModePoint;
use super::style::{ACCENT, COOL, GRID, TEXT, TEXT_WEAK};
use super::view::TactusEditor;
use egui::{self, pos2, vec2, Align2, Color32, FontId, Pos2, Rect, Sense, Stroke, StrokeKind, Ui};
use nice_plug::prelude::*;
use std::collections::VecDeque;

/// Frequency axis of the mode view (Hz, log).
const F_LO: f32 = 20.0;
const F_HI: f32 = 20_000.0;
/// Level axis of the mode view (dB below the strongest mode).
const DB_FLOOR: f32 = -90.0;
/// Pad speed scale: a drag across the whole pad in one second is this many m/s.
const PAD_M_PER_S_PER_WIDTH: f32 = 0.5;

#[derive(Default)]
pub(super) struct PadState {
    pub(super) dragging: bool,
    pub(super) last_pos: Option<Pos2>,
    pub(super) speed: f32,
    pub(super) trail: VecDeque<Pos2>,
}

impl TactusEditor {
    /// Frequency (log) × level bars; colour and opacity follow the decay rate.
    pub(super) fn mode_view(&self, ui: &mut Ui) {
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
    pub(super) fn motion_pad(&mut self, ui: &mut Ui, setter: &ParamSetter, dt: f32) {
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

    pub(super) fn meters(&self, ui: &mut Ui) {
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
