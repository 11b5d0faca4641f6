//! The engine's results in the file formats of [`crate::io`]: the formats are
//! plain data owned by `io` (which knows nothing of the engine), and the
//! conversions from the engine's types live here.

use model::Arm;

use super::ParamKey;
use super::identify::{Estimate, Identified};
use crate::io::calibration_file::{
    CalibrationFile, ErrorStats, FittedParam, SCHEMA, SCHEMA_VERSION, ValidationSummary,
};

impl From<&Estimate> for FittedParam {
    fn from(e: &Estimate) -> Self {
        Self {
            name: e.id.name().into_owned(),
            error: e.error,
            value: e.value,
            std: e.std,
        }
    }
}

/// The calibration file of an identification from `nominal`: `removed` are
/// the candidates left out as unidentifiable, `poses_used` and `loads_kg`
/// the measurements fitted, `fit_residual` the error on them.
pub fn calibration_file(
    nominal: &Arm<f64>,
    identified: &Identified,
    removed: &[ParamKey],
    poses_used: Vec<u32>,
    loads_kg: Vec<f64>,
    fit_residual: ErrorStats,
    validation: Option<ValidationSummary>,
) -> CalibrationFile {
    CalibrationFile {
        schema: SCHEMA.into(),
        schema_version: SCHEMA_VERSION,
        option: identified.option,
        nominal: *nominal,
        arm: identified.arm,
        parameters: identified.estimates.iter().map(FittedParam::from).collect(),
        at_bound: identified
            .diagnostics
            .at_bound
            .iter()
            .map(|p| p.name().into_owned())
            .collect(),
        removed: removed.iter().map(|p| p.name().into_owned()).collect(),
        poses_used,
        loads_kg,
        fit_residual,
        validation,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use model::ParamId;

    use crate::calib::ModelOption;
    use crate::calib::identify::Diagnostics;
    use crate::calib::testing::rigid_nominal;

    #[test]
    fn an_identification_becomes_a_calibration_file_that_reads_back() {
        let nominal = rigid_nominal();
        let k2 = ParamId::from_name("k2").unwrap();
        let k6 = ParamId::from_name("k6").unwrap();
        let identified = Identified {
            option: ModelOption::Elastic,
            arm: nominal.with_errors(&[k2], &[0.1]),
            estimates: vec![
                Estimate {
                    id: k2.into(),
                    error: 0.1,
                    value: 0.1,
                    std: Some(1e-3),
                },
                Estimate {
                    id: k6.into(),
                    error: 0.0,
                    value: 0.0,
                    std: None,
                },
            ],
            diagnostics: Diagnostics {
                termination: "Converged".into(),
                converged: true,
                evaluations: 3,
                active_set_rounds: 1,
                irls_rounds: 1,
                at_bound: vec![k6.into()],
                rms_before_m: 0.01,
                rms_after_m: 0.001,
                sigma_m: 0.001,
                condition: 1.0,
            },
            fit_residual: ErrorStats::of(&[0.001]),
            outliers: vec![],
        };
        let k1 = ParamId::from_name("k1").unwrap();
        let file = calibration_file(
            &nominal,
            &identified,
            &[k1.into()],
            vec![1, 2],
            vec![0.0663],
            ErrorStats::of(&[0.001]),
            None,
        );
        assert_eq!(file.option, ModelOption::Elastic);
        assert_eq!(file.arm, identified.arm);
        assert_eq!(file.at_bound, ["k6"]);
        assert_eq!(file.removed, ["k1"]);
        assert_eq!(
            file.parameters[0],
            FittedParam {
                name: "k2".into(),
                error: 0.1,
                value: 0.1,
                std: Some(1e-3)
            }
        );
        assert_eq!(CalibrationFile::parse(&file.to_json()).unwrap(), file);
    }
}
