//! Tests of `calibration_file`.

use super::test_support::sample_file;
use super::*;
use crate::param_key::ParamKey;

/// The first target by default, another by name, both arms carrying its
/// tool point; an unknown name lists the names; a file without targets is
/// itself and refuses any name.
#[test]
fn target_selection_moves_both_tool_points() {
    let mut file = sample_file();
    assert_eq!(file.for_target(None).as_ref(), Ok(&file));
    let e = file.for_target(Some("m1")).unwrap_err();
    assert!(e.contains("`m1`") && e.contains("target` column"), "{e}");
    let stats = ErrorStats::of(&[0.001]);
    for (name, tool_m) in [("m0", file.arm.tool.xyz), ("m1", [0.0, 0.03, 0.05])] {
        file.targets.push(TargetTool {
            name: name.into(),
            tool_m,
            fit_residual: stats,
            validation_after: None,
        });
    }
    file.parameters.push(FittedParam {
        name: ParamKey::from_name("tool[1].y").unwrap(),
        error: 0.03,
        value: 0.03,
        std: None,
    });
    let file = CalibrationFile::parse(&file.to_json()).unwrap();
    let (nominal, arm) = file.for_target(Some("m1")).unwrap().board_arms();
    assert_eq!(nominal.tool.xyz, [0.0, 0.03, 0.05]);
    assert_eq!(arm.tool.xyz, [0.0, 0.03, 0.05]);
    assert_eq!(arm.joints, file.arm.joints);
    assert_eq!(nominal.joints, file.nominal.joints);
    let (nominal, arm) = file.for_target(None).unwrap().board_arms();
    assert_eq!(
        (nominal.tool.xyz, arm.tool.xyz),
        (file.arm.tool.xyz, file.arm.tool.xyz)
    );
    let e = file.for_target(Some("m9")).unwrap_err();
    assert!(e.contains("`m9`") && e.contains("m0, m1"), "{e}");
    // A parameter of a target the file does not list, a repeated name, a
    // first target away from the arm's tool point: refused with the key.
    let json = file.to_json();
    let refused = |text: &str| CalibrationFile::parse(text).unwrap_err().to_string();
    let e = refused(&json.replacen("tool[1].y", "tool[2].y", 1));
    assert!(e.contains("parameters[2].name"), "{e}");
    let e = refused(&json.replacen("\"m1\"", "\"m0\"", 1));
    assert!(e.contains("targets[2]") && e.contains("`m0` again"), "{e}");
    let mut moved = file.clone();
    moved.targets[0].tool_m[0] += 0.01;
    let e = refused(&moved.to_json());
    assert!(e.contains("targets[1].tool_m"), "{e}");
}

/// The board's nominal arm stands on the calibrated base; everything else,
/// the tool included, is the file's nominal arm.
#[test]
fn the_boards_nominal_arm_stands_where_the_calibrated_one_does() {
    let mut file = sample_file();
    file.arm.base.xyz = [0.01, -0.02, -0.06];
    file.arm.base.rpy = [0.02, 0.0, 0.1];
    file.arm.tool.xyz[1] += 0.004;
    let (nominal, arm) = file.board_arms();
    assert_eq!(arm, file.arm);
    assert_eq!(nominal.base, file.arm.base);
    let mut rest = nominal;
    rest.base = file.nominal.base;
    assert_eq!(rest, file.nominal);
}
