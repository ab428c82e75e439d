//! Segmentation settings as a view keeps them: the method and every
//! threshold, the unused ones too, so that a stored view rebuilds with
//! what was uploaded (DMesh Sec. 5, Eq. 6, 9 and 10). The server stores
//! and reads them; `to_engine` gives the build's form.

use serde::{Deserialize, Serialize};

/// Segmentation settings as stored and sent.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SegmentationSpec {
    /// `orthogonality`, `disparity`, `connectedness` or `none`.
    pub method: SegmentMethod,
    /// Orthogonality angle in degrees.
    pub omega: f64,
    /// Disparity threshold.
    pub sigma: f64,
    /// Connectedness threshold.
    pub kappa: f64,
    /// Depth-range gate.
    pub lambda: f64,
}

/// The rubber-sheet test of a view, by name: what is stored, sent and
/// typed. The build runs a [`super::segmentation::Method`], which carries the
/// test's threshold ([`SegmentationSpec::to_engine`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum SegmentMethod {
    /// DMesh Eq. 10.
    Orthogonality,
    /// DMesh Eq. 9.
    Disparity,
    /// DMesh Eq. 6.
    Connectedness,
    /// Invalid samples only.
    None,
}

impl SegmentMethod {
    /// Its names, as the upload form's `segment` field and `dmesh mesh
    /// --segment` take them (and as JSON writes them).
    pub const NAMES: [(&'static str, Self); 4] = [
        ("orthogonality", Self::Orthogonality),
        ("disparity", Self::Disparity),
        ("connectedness", Self::Connectedness),
        ("none", Self::None),
    ];
}

impl std::str::FromStr for SegmentMethod {
    type Err = crate::Error;

    fn from_str(s: &str) -> crate::Result<Self> {
        crate::by_name(&Self::NAMES, s).ok_or_else(|| {
            crate::Error::invalid(format!(
                "segmentation method {s:?} is unknown; use orthogonality, disparity, connectedness or none"
            ))
        })
    }
}

impl Default for SegmentationSpec {
    fn default() -> Self {
        Self {
            method: SegmentMethod::Orthogonality,
            omega: super::segmentation::OMEGA_DEG,
            sigma: super::segmentation::SIGMA,
            kappa: super::segmentation::KAPPA,
            lambda: super::segmentation::LAMBDA,
        }
    }
}

impl SegmentationSpec {
    /// Checks every threshold, the unused ones too (an upload that sends
    /// `omega=200` with `segment=none` is as wrong as one that uses it).
    pub fn validate(&self) -> crate::Result<()> {
        use super::segmentation::Method;
        let all = [
            Method::Orthogonality { omega_deg: self.omega },
            Method::Disparity { sigma: self.sigma },
            Method::Connectedness { kappa: self.kappa },
        ];
        for method in all {
            super::segmentation::Segmentation {
                method,
                lambda: self.lambda,
            }
            .validate()?;
        }
        Ok(())
    }

    /// The engine's form.
    pub fn to_engine(&self) -> super::segmentation::Segmentation {
        use super::segmentation::Method;
        let method = match self.method {
            SegmentMethod::Orthogonality => Method::Orthogonality { omega_deg: self.omega },
            SegmentMethod::Disparity => Method::Disparity { sigma: self.sigma },
            SegmentMethod::Connectedness => Method::Connectedness { kappa: self.kappa },
            SegmentMethod::None => Method::None,
        };
        super::segmentation::Segmentation {
            method,
            lambda: self.lambda,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_threshold_is_checked_whatever_the_method() {
        assert!(SegmentationSpec::default().validate().is_ok());
        for bad in [
            SegmentationSpec {
                method: SegmentMethod::None,
                omega: 200.0,
                ..Default::default()
            },
            SegmentationSpec {
                method: SegmentMethod::Orthogonality,
                sigma: -1.0,
                ..Default::default()
            },
            SegmentationSpec {
                method: SegmentMethod::Disparity,
                kappa: f64::NAN,
                ..Default::default()
            },
            SegmentationSpec {
                lambda: -0.5,
                ..Default::default()
            },
        ] {
            assert!(bad.validate().is_err(), "{bad:?}");
        }
    }

    #[test]
    fn a_method_has_one_name_typed_stored_and_sent() {
        for (name, method) in SegmentMethod::NAMES {
            assert_eq!(name.parse::<SegmentMethod>().unwrap(), method);
            assert_eq!(serde_json::to_string(&method).unwrap(), format!("\"{name}\""));
        }
        let unknown = "sideways".parse::<SegmentMethod>().unwrap_err().to_string();
        assert!(
            unknown.contains("orthogonality, disparity, connectedness or none"),
            "{unknown}"
        );
    }
}
