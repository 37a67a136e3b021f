//! The shipped calibrations, `calibration/bc.json` and `calibration/aopi.json`: the constants
//! `advise calibrate` fitted to the paper's starting conditions, compiled in. This is the one
//! place their text is read: the interception world and teacher
//! ([`crate::task::interception`]), the A-OPI pilot (`experiment::pilot`) and the fit report the
//! experiments print beside their figures (`experiment::calibrate`) all parse it here.

use serde::de::DeserializeOwned;

/// One shipped calibration file: one per study `advise calibrate` fits.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Shipped {
    /// `calibration/bc.json`: the interception world and teacher.
    Bc,
    /// `calibration/aopi.json`: the A-OPI pilot and its arms' limits.
    Aopi,
}

impl Shipped {
    /// The file's text as shipped.
    pub fn text(self) -> &'static str {
        match self {
            Shipped::Bc => include_str!("../../../../calibration/bc.json"),
            Shipped::Aopi => include_str!("../../../../calibration/aopi.json"),
        }
    }

    /// The file read as `T`: the whole file, or the fields `T` names (unless `T` denies the
    /// others).
    pub fn read<T: DeserializeOwned>(self) -> serde_json::Result<T> {
        serde_json::from_str(self.text())
    }

    /// The report of what the constants were fitted to and how closely (the file's
    /// `calibration`, `experiment::calibrate::FitReport`); `None` if the file has none (not
    /// calibrated yet).
    pub fn fit_report(self) -> Option<serde_json::Value> {
        let v: serde_json::Value = self.read().ok()?;
        v.get("calibration").cloned()
    }
}
