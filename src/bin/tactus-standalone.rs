//! Tactus as a desktop application: the plugin with its editor, connected straight to JACK or
//! ALSA (or a dummy backend). `tactus-standalone --help` lists the audio/MIDI options.

use tactus::plugin::Tactus;

fn main() {
    if !nice_plug::nice_export_standalone::<Tactus>() {
        std::process::exit(1);
    }
}
