//! A stand-in host for driving [`Tactus`] without a plugin host (benchmarks, tests): it
//! activates the plugin, hands `process` a queue of note events and a stopped transport, and
//! ignores every request. The plugin itself never uses it.

use super::Tactus;
use nice_plug::context::process::SendEventError;
use nice_plug::prelude::*;

/// The host stand-in: a [`ProcessContext`] and an [`ActivateContext`] for [`Tactus`].
pub struct StubHost {
    /// What `process` reads as the transport (stopped unless a caller changes it).
    pub transport: Transport,
    events: Vec<PluginNoteEvent<Tactus>>,
    next: usize,
}

impl StubHost {
    /// A host at `sample_rate_hz` with no events queued.
    pub fn new(sample_rate_hz: f32) -> Self {
        Self {
            transport: Transport::new(sample_rate_hz),
            events: Vec::new(),
            next: 0,
        }
    }

    /// Queues the note events of the next `process` call (sorted by timing, as hosts send them).
    pub fn set_events(&mut self, events: Vec<PluginNoteEvent<Tactus>>) {
        self.events = events;
        self.next = 0;
    }

    /// Activates `plugin` with its stereo layout at `sample_rate_hz`, blocks of up to
    /// `max_block` samples, in `mode`; returns what `activate` returns.
    pub fn activate(
        &mut self,
        plugin: &mut Tactus,
        sample_rate_hz: f32,
        max_block: u32,
        mode: ProcessMode,
    ) -> bool {
        let config = BufferConfig {
            sample_rate: sample_rate_hz,
            min_buffer_size: None,
            max_buffer_size: max_block,
            process_mode: mode,
        };
        plugin.activate(&Tactus::AUDIO_IO_LAYOUTS[0], &config, self)
    }
}

impl ProcessContext<Tactus> for StubHost {
    fn plugin_api(&self) -> PluginApi {
        PluginApi::Clap
    }
    fn execute_background(&self, _task: ()) {}
    fn execute_gui(&self, _task: ()) {}
    fn transport(&self) -> &Transport {
        &self.transport
    }
    fn next_event(&mut self) -> Option<PluginNoteEvent<Tactus>> {
        let event = self.events.get(self.next).copied();
        self.next += 1;
        event
    }
    fn try_send_event(
        &mut self,
        event: PluginNoteEvent<Tactus>,
    ) -> Result<(), (PluginNoteEvent<Tactus>, SendEventError)> {
        // Tactus declares no note output.
        Err((event, SendEventError::NoOutputBuffer))
    }
    fn set_latency_samples(&self, _samples: u32) {}
    fn request_restart(&self) {}
    fn set_current_voice_capacity(&self, _capacity: u32) {}
}

impl ActivateContext<Tactus> for StubHost {
    fn plugin_api(&self) -> PluginApi {
        PluginApi::Clap
    }
    fn execute(&self, _task: ()) {}
    fn set_latency_samples(&self, _samples: u32) {}
    fn set_current_voice_capacity(&self, _capacity: u32) {}
}
