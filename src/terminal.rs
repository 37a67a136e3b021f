//! The terminal a person sits at, given to the library: their keys in raw mode for a drive
//! ([`TerminalConsole`], the library's [`Console`]) and progress bars on standard error
//! ([`Bars`], the library's [`Painter`]). [`install`] hands both to the library once, at start.

use std::io::IsTerminal;
use std::time::Duration;

use advise::backend::BackendError;
use advise::backend::teleop::{Console, Key, KeySource, install_console};
use advise::progress::{Bar, Painter, Unit};

/// Install the terminal into the library: a drive's keys and lines ([`TerminalConsole`]) and
/// progress bars ([`Bars`]).
pub fn install() {
    install_console(Box::new(TerminalConsole));
    advise::progress::install(Box::new(Bars));
}

/// The person at this terminal: present when standard input is a terminal; keys in raw mode;
/// lines on standard error (dropped when it is closed).
pub struct TerminalConsole;

impl Console for TerminalConsole {
    fn present(&self) -> bool {
        std::io::stdin().is_terminal()
    }

    fn keys(&self) -> Result<Box<dyn KeySource>, BackendError> {
        Ok(Box::new(TerminalKeys::open()?))
    }

    fn show(&self, text: std::fmt::Arguments<'_>) {
        use std::io::Write as _;
        let _ = std::io::stderr().lock().write_fmt(text);
    }
}

/// The terminal's keys, in raw mode while this lives (restored on drop, on error and on panic's
/// unwinding alike).
pub struct TerminalKeys {
    _raw: RawMode,
}

struct RawMode;

impl Drop for RawMode {
    fn drop(&mut self) {
        let _ = crossterm::terminal::disable_raw_mode();
    }
}

impl TerminalKeys {
    /// Raw mode on the terminal; an error when there is none.
    pub fn open() -> Result<TerminalKeys, BackendError> {
        crossterm::terminal::enable_raw_mode()?;
        Ok(TerminalKeys { _raw: RawMode })
    }
}

impl KeySource for TerminalKeys {
    fn keys(&mut self, wait: Duration) -> Result<Vec<Key>, BackendError> {
        use crossterm::event::{self, Event, KeyCode, KeyEventKind, KeyModifiers};
        let mut out = Vec::new();
        let mut wait = wait;
        // Bounded: a held key's repeats cannot keep the control loop from its next step.
        while out.len() < 64 && event::poll(wait)? {
            wait = Duration::ZERO;
            if let Event::Key(k) = event::read()?
                && k.kind != KeyEventKind::Release
            {
                let key = match k.code {
                    KeyCode::Up => Some(Key::Faster),
                    KeyCode::Down => Some(Key::Slower),
                    KeyCode::Left => Some(Key::Left),
                    KeyCode::Right => Some(Key::Right),
                    KeyCode::Enter | KeyCode::Esc => Some(Key::End),
                    KeyCode::Tab => Some(Key::Toggle),
                    // Raw mode turns Ctrl-C into a key: it ends a drive at once, and stops a run.
                    KeyCode::Char('c') if k.modifiers.contains(KeyModifiers::CONTROL) => {
                        Some(Key::Interrupt)
                    }
                    KeyCode::Char(c) => Key::from_char(c),
                    _ => None,
                };
                out.extend(key);
            }
        }
        Ok(out)
    }
}

/// Progress bars on standard error, drawn only when it is a terminal (never into a pipe).
pub struct Bars;

impl Painter for Bars {
    fn bar(&self, len: u64, unit: Unit, message: &str) -> Box<dyn Bar> {
        if !std::io::stderr().is_terminal() {
            return Box::new(Indicatif(indicatif::ProgressBar::hidden()));
        }
        let bar = indicatif::ProgressBar::new(len);
        let template = match unit {
            Unit::Items => "{msg:28} {bar:40} {pos}/{len} [{elapsed}]",
            Unit::Rows => "{msg} {bar:40} {human_pos}/{human_len} rows ({eta} left)",
            Unit::Bytes => "{msg} {bar:40} {bytes}/{total_bytes} ({eta} left)",
        };
        if let Ok(style) = indicatif::ProgressStyle::with_template(template) {
            bar.set_style(style);
        }
        bar.set_message(message.to_string());
        Box::new(Indicatif(bar))
    }
}

struct Indicatif(indicatif::ProgressBar);

impl Bar for Indicatif {
    fn inc(&self, n: u64) {
        self.0.inc(n);
    }

    fn set_position(&self, done: u64) {
        self.0.set_position(done);
    }

    fn set_message(&self, message: &str) {
        self.0.set_message(message.to_string());
    }

    fn finish(&self) {
        self.0.finish_and_clear();
    }
}
