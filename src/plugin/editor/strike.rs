//! The strike pad: pressing it plays the current gesture as a note whose velocity is the
//! press's horizontal position (left soft, right hard); releasing it is the note-off (a rattle
//! stops shaking). Presses reach the audio thread through the lock-free
//! [`crate::plugin::strike_pad::PadQueue`] and play through the same code as the host's notes,
//! whether or not the host's transport runs.

use super::style::{ACCENT, GRID, STRIKE_RAMP, TEXT, TEXT_WEAK};
use super::view::TactusEditor;
use crate::plugin::params::GestureChoice;
use crate::plugin::strike_pad::{velocity_at, PadEvent};
use egui::{self, pos2, vec2, Align2, FontId, Sense, Shape, Stroke, Ui};
use nice_plug::prelude::*;

/// What the pad is doing.
#[derive(Default)]
pub(super) struct StrikeState {
    /// Horizontal position (0..1) of the press being held.
    held: Option<f32>,
    /// Velocity of the last press, shown until the next one.
    last_velocity: Option<f32>,
    /// A release the full queue refused: pushed again every frame until taken, so a held
    /// rattle always gets its note-off.
    release_pending: bool,
}

impl TactusEditor {
    /// Draws the pad `width` wide in the rest of `ui`'s height and turns a press and its
    /// release into pad events. The group's width, not the `Ui`'s: a row whose value text
    /// overflows widens the `Ui`, and the pad would run under the group's edge.
    pub(super) fn strike_pad(&mut self, ui: &mut Ui, width: f32) {
        let size = vec2(width, ui.available_height());
        let (resp, painter) = ui.allocate_painter(size, Sense::click_and_drag());
        let r = resp.rect;
        painter.rect_filled(r, 4.0, ui.visuals().extreme_bg_color);
        // The velocity wedge: its height is the velocity a press at that x plays.
        let wedge = r.shrink2(vec2(6.0, 20.0));
        painter.add(Shape::convex_polygon(
            vec![wedge.left_bottom(), wedge.right_bottom(), wedge.right_top()],
            STRIKE_RAMP,
            Stroke::NONE,
        ));
        for q in 1..4 {
            let x = wedge.left() + wedge.width() * q as f32 / 4.0;
            painter.line_segment([pos2(x, r.top() + 4.0), pos2(x, r.bottom() - 4.0)], (1.0, GRID));
        }

        if self.strike.release_pending && self.strike_queue.push(PadEvent::Release) {
            self.strike.release_pending = false;
        }
        let down = resp.is_pointer_button_down_on();
        if down && self.strike.held.is_none() {
            if let Some(pos) = resp.interact_pointer_pos() {
                let x = ((pos.x - wedge.left()) / wedge.width().max(1.0)).clamp(0.0, 1.0);
                let velocity = velocity_at(x);
                if self.strike_queue.push(PadEvent::Press { velocity }) {
                    self.strike.held = Some(x);
                    self.strike.last_velocity = Some(velocity);
                }
            }
        } else if !down && self.strike.held.is_some() {
            self.release_strike();
        }

        if let Some(x) = self.strike.held {
            let px = wedge.left() + x * wedge.width();
            painter.line_segment(
                [pos2(px, r.top() + 4.0), pos2(px, r.bottom() - 4.0)],
                (2.0, ACCENT),
            );
            painter.circle_filled(pos2(px, wedge.bottom() - x * wedge.height()), 5.0, ACCENT);
            ui.ctx().request_repaint();
        }
        let small = FontId::proportional(10.0);
        let gesture = GestureChoice::variants()[self.params.gesture.value().to_index()];
        painter.text(
            r.left_top() + vec2(6.0, 4.0),
            Align2::LEFT_TOP,
            format!("press to play · {gesture}"),
            FontId::proportional(12.0),
            TEXT,
        );
        if let Some(v) = self.strike.last_velocity {
            painter.text(
                r.right_top() + vec2(-6.0, 4.0),
                Align2::RIGHT_TOP,
                format!("velocity {:.0}", v * 127.0),
                FontId::monospace(11.0),
                TEXT,
            );
        }
        painter.text(
            r.left_bottom() + vec2(6.0, -4.0),
            Align2::LEFT_BOTTOM,
            "soft",
            small.clone(),
            TEXT_WEAK,
        );
        painter.text(
            r.right_bottom() + vec2(-6.0, -4.0),
            Align2::RIGHT_BOTTOM,
            "hard",
            small,
            TEXT_WEAK,
        );
        resp.on_hover_cursor(egui::CursorIcon::PointingHand);
    }

    /// Ends a held press: its note-off, now or, if the queue is full, from the next frame on.
    pub(super) fn release_strike(&mut self) {
        if self.strike.held.take().is_some() && !self.strike_queue.push(PadEvent::Release) {
            self.strike.release_pending = true;
        }
    }
}
