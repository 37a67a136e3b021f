//! The platform's faults: critical faults that disable it, and the fault log, a ring of entries
//! written each time the fault status words gain a bit, in the layout the vendor's parser reads.

use super::platform::Platform;
use crate::backend::rmp::codec::{
    self, FAULT_LOG_WORDS, OpState,
    fault_log::{self, entry},
};

/// The fault-log format version the emulator reports (the real platform's value is not public).
const FAULT_LOG_VERSION: u32 = 1;
/// The emulated platform has powered up once.
const POWER_CYCLES: u32 = 1;

impl Platform {
    /// Raise critical fault bits in word 0 (a test hook); the platform disables its motors.
    pub fn raise_critical_fault(&mut self, bits: u32) {
        self.faults[0] |= bits & codec::CRITICAL_FAULT_MASK;
        self.state = OpState::Disabled;
        self.log_new_faults();
    }

    /// Write a fault-log entry when the fault words hold a bit the last entry did not. The log is
    /// a ring of [`fault_log::MAX_ENTRIES`] entries, as on the platform.
    pub(super) fn log_new_faults(&mut self) {
        if self
            .faults
            .iter()
            .zip(&self.logged)
            .all(|(f, l)| f & !l == 0)
        {
            return;
        }
        self.logged = self.faults;
        let i = if self.log_count == 0 {
            0
        } else {
            (self.log_latest + 1) % fault_log::MAX_ENTRIES
        };
        let [fsw0, fsw1, fsw2, fsw3] = self.faults;
        let run_time_s = self.t_s as u32;
        let e = &mut self.log[i];
        *e = [0; fault_log::ENTRY_WORDS];
        // No calendar on the emulated platform: its clock starts at 2011-01-01 at power-up.
        e[entry::TIME_STAMP_S] = run_time_s;
        e[entry::RUN_TIME_S] = run_time_s;
        e[entry::POWER_CYCLE] = POWER_CYCLES;
        // The fault status words split into their groups, each shifted down to bit 0 (research
        // notes, section 3.2: word 0 architecture 0-11 and critical 12-31, word 1 comm 0-15 and
        // internal 16-19, word 2 sensor 0-15 and BSA 16-31, word 3 MCU).
        e[entry::CRITICAL] = (fsw0 & codec::CRITICAL_FAULT_MASK) >> 12;
        e[entry::COMM] = fsw1 & 0xFFFF;
        e[entry::SENSOR] = fsw2 & 0xFFFF;
        e[entry::BSA] = fsw2 >> 16;
        e[entry::MCU] = fsw3;
        e[entry::ARCHITECTURE] = fsw0 & 0xFFF;
        e[entry::INTERNAL] = (fsw1 >> 16) & 0xF;
        self.log_latest = i;
        self.log_count = (self.log_count + 1).min(fault_log::MAX_ENTRIES);
    }

    /// The 311-word fault log in the layout the vendor's fault-log parser reads
    /// ([`codec::fault_log`]): the header, then one entry for each time the fault words gained a
    /// bit since power-up (the emulator keeps no log across power cycles).
    pub fn fault_log(&self) -> Vec<u32> {
        let mut w = vec![0u32; FAULT_LOG_WORDS];
        w[fault_log::LOG_VERSION] = FAULT_LOG_VERSION;
        w[fault_log::LOG_SIZE_BYTES] = (FAULT_LOG_WORDS * 4) as u32;
        w[fault_log::ENTRY_COUNT] = self.log_count as u32;
        w[fault_log::LATEST_ENTRY] = self.log_latest as u32;
        // An emulator's serial number: "EMU" and the platform id.
        w[fault_log::SERIAL_HIGH] = u32::from_be_bytes(*b"\0EMU");
        w[fault_log::SERIAL_LOW] = self.cfg.platform as u32;
        w[fault_log::ACCUMULATED_TIME_S] = self.t_s as u32;
        w[fault_log::ODOMETER_M] = self.odometer_m as u32;
        w[fault_log::POWER_CYCLES] = POWER_CYCLES;
        for (i, e) in self.log.iter().enumerate() {
            let at = fault_log::ENTRIES + i * fault_log::ENTRY_WORDS;
            w[at..at + fault_log::ENTRY_WORDS].copy_from_slice(e);
        }
        w
    }
}
