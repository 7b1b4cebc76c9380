//! The libraries' messages (the `log` facade) on stderr: warnings as `warning: …`, notes as
//! they are; `HAMEL_LOG=debug` (or `trace`) shows more, e.g. each exact check of a search.

use log::{Level, LevelFilter, Log, Metadata, Record};

struct Stderr;

impl Log for Stderr {
    fn enabled(&self, metadata: &Metadata) -> bool {
        metadata.level() <= log::max_level()
    }

    fn log(&self, record: &Record) {
        if !self.enabled(record.metadata()) {
            return;
        }
        match record.level() {
            Level::Error => eprintln!("error: {}", record.args()),
            Level::Warn => eprintln!("warning: {}", record.args()),
            Level::Info => eprintln!("{}", record.args()),
            Level::Debug | Level::Trace => eprintln!("[{}] {}", record.target(), record.args()),
        }
    }

    fn flush(&self) {}
}

/// Send the libraries' messages to stderr, at the level `HAMEL_LOG` names (default: info).
pub fn init() {
    static LOGGER: Stderr = Stderr;
    let level = std::env::var("HAMEL_LOG")
        .ok()
        .and_then(|v| v.parse::<LevelFilter>().ok())
        .unwrap_or(LevelFilter::Info);
    if log::set_logger(&LOGGER).is_ok() {
        log::set_max_level(level);
    }
}
